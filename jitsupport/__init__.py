"""What the compiled kernels of the autopilot and the world need beyond numba's public API.

The one home of the project's JIT support, imported by ``fcu`` and ``sim`` alike and
importing none of the project's packages:

- :mod:`jitsupport.layout`: named state in one flat array (:class:`Layout`), so that a kernel
  takes a filter's whole state as one argument without hand-counted offsets;
- :mod:`jitsupport.cache`: keeps numba's on-disk cache from running stale code;
- :mod:`jitsupport.views`: array views that cost no reference counting;
- :mod:`jitsupport.calls`: calls of a kernel past numba's type dispatch.

The last two go below numba's ordinary API; docs/design.md ("Compiled-tick internals")
gives what each is worth, measured side by side against plain numba.
"""
