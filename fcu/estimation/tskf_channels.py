"""The TSKF's measurement channels: the common ones, with the tables that map a tick's
averaged samples back to the tick.

Samples of one kind within a tick are averaged; their mean time lies ``delta`` before the
tick, and the row is mapped back to that time to first order,
``y = S x(t - delta) = S (x - delta (A_c x + B_c u + g_c))``, i.e. ``C = S (I - delta A_c)``
with the known input part ``delta S (B_c u + g_c)`` moved to the measurement side (non-zero
only for the accelerometer: the thrusts it reads respond to the PWM within the tick).
:class:`TskfChannelSet` keeps ``S A_c``, ``S B_c`` and ``S g_c`` of the flight and ground
hover models (:mod:`fcu.estimation.tskf_model`) for :func:`fcu.estimation.tskf_kernel.tskf_tick`.
"""

from __future__ import annotations

import numpy as np

from fcu.estimation import screening
from fcu.estimation.channels import Channel, ChannelSet
from fcu.estimation.tskf_model import LinearHoverModel

__all__ = ["MAPPED", "TskfChannelSet"]


class TskfChannelSet(ChannelSet):
    """One height source's channels, stacked, with ``S A_c``, ``S B_c`` and ``S g_c`` of the
    flight model (index 0) and the ground model (index 1): ``sel_a`` (2, rows, 16), ``sel_b``
    (2, rows, 4), ``sel_g`` (2, rows), and ``mapped`` (n_ch,), whether the input's share
    of a channel's back-mapping is non-zero. For
    :func:`~fcu.estimation.tskf_kernel.tskf_tick`, ``tables`` carries ``sel_a``, ``sel_b``
    and ``sel_g`` after the common tables, and ``layout`` ``mapped`` in its column
    ``MAPPED``."""

    def __init__(self, channels: tuple[Channel, ...], flight: LinearHoverModel,
                 ground: LinearHoverModel) -> None:
        super().__init__(channels)
        models = (flight, ground)
        # S A_c of the flight and ground models, for C = S (I - delta A_c)
        self.sel_a = np.ascontiguousarray([self.sel_stack @ lm.a_c for lm in models])
        # S B_c and S g_c: the input's share of the back-mapping, x(t - delta) = x - delta
        # (A_c x + B_c u + g_c); non-zero only for the accelerometer, which reads the thrusts
        self.sel_b = np.ascontiguousarray([self.sel_stack @ lm.b_c for lm in models])
        self.sel_g = np.ascontiguousarray([self.sel_stack @ lm.g_c for lm in models])
        self.mapped = np.array([bool(np.any(self.sel_b[0, i0:i1]) or np.any(self.sel_g[0, i0:i1]))
                                for i0, i1 in self.rows_list])
        self.tables = np.concatenate((self.tables, self.sel_a.ravel(), self.sel_b.ravel(),
                                      self.sel_g.ravel()))
        self.layout = np.ascontiguousarray(np.column_stack((self.layout, self.mapped)),
                                           dtype=np.int64)


MAPPED = screening.PICKS + 1  # column of a TskfChannelSet's layout: the input is back-mapped
