"""Screening of a tick's measurements against the prior, compiled (the kernels behind
:class:`fcu.estimation.estimator.TickEstimator`'s screening; the rule is in that module's
docstring), and the layout of the tables the filters' tick kernels read.
"""

from __future__ import annotations

import numpy as np
from numba import njit

import fcu.floats
from fcu.estimation.small_matrix import nonzero_columns, spd_quadratic
from fcu.estimation.state import STATE_DIM, Z_INDEX, FloatArray
from fcu.floats import wrap_pi
from jitsupport import views as kernel_views
from jitsupport.cache import drop_stale_kernels
from jitsupport.views import carve, refcount_free_kernel, shaped

# screen_channel compiles in the kernels of small_matrix and kernel_views
drop_stale_kernels(__file__, fcu.floats.__file__, kernel_views.__file__)

ChannelStatus = str  # "applied" | "rejected" | "excluded" | "skipped"


@njit(cache=True, error_model="numpy")
def select(sel: FloatArray, a: FloatArray, picks: bool) -> FloatArray:
    """``S a`` for ``a`` of shape (16,) or (16, k). ``picks``: each row of ``S`` is a single
    entry of +-1, so the product is those entries of ``a`` (signed), which is what the
    matrix product computes too, to the bit, without a BLAS call."""
    if not picks:
        return sel @ a
    out = np.zeros((sel.shape[0],) + a.shape[1:])
    for i in range(sel.shape[0]):
        for k in range(sel.shape[1]):
            if sel[i, k] != 0.0:
                out[i] = sel[i, k] * a[k]
    return out


@njit(cache=True, error_model="numpy")
def screen_channel(sel: FloatArray, z: FloatArray, x: FloatArray, p_mat: FloatArray,
                   r_var: float, wrap_yaw: bool) -> tuple[FloatArray, FloatArray, float]:
    """One channel's screening against the prior (module docstring), compiled.

    Returns ``nu = z - S x`` (third entry wrapped to [-pi, pi) when ``wrap_yaw``), the
    diagonal of ``S P S' + R`` (``R = r_var I``) and ``NIS = nu' (S P S' + R)^-1 nu``
    (:func:`screen_channel_into` into fresh arrays).
    """
    m = sel.shape[0]
    nu = np.empty(m)
    var = np.empty(m)
    nis = screen_channel_into(nu, var, sel, z, x, p_mat, r_var, wrap_yaw,
                              np.empty(SCREEN_SCRATCH))
    return nu, var, nis


SCREEN_SCRATCH = 16 * 17 + 2 * 16 * 16 + 16
"""Size of the scratch :func:`screen_channel_into` works in (channels of up to 16 rows)."""


# inlined into screen_channels_into (a few calls per tick): the call, with its many array
# arguments, cost about as much as a small channel's arithmetic
@njit(cache=True, error_model="numpy", inline="always")
def screen_channel_into(nu: FloatArray, var: FloatArray, sel: FloatArray, z: FloatArray,
                        x: FloatArray, p_mat: FloatArray, r_var: float, wrap_yaw: bool,
                        scratch: FloatArray) -> float:
    """:func:`screen_channel` written into ``nu`` and ``var`` (m,); returns the NIS
    (``scratch``: at least :data:`SCREEN_SCRATCH` entries).

    A row of ``S`` picks one or a few state entries: ``S P S'`` is summed over the non-zero
    entries of ``S`` only (listed once), so for pick rows it is a sub-matrix of ``P``, and
    ``S P`` is never formed in full. The products are those of ``(S P) S'`` with the zeros
    of ``S`` skipped, in the same order.
    """
    m, n = sel.shape
    # each matrix keeps the room of its largest size (m, n <= 16)
    nz, o = carve(scratch, 0, (m, n + 1), 16 * 17)
    s_mat, o = carve(scratch, o, (m, m), 16 * 16)
    low, o = carve(scratch, o, (m, m), 16 * 16)
    tmp, o = carve(scratch, o, (m,))
    # the non-zero entries of each row of S
    nonzero_columns(nz, sel)
    for r in range(m):
        # nu = z - S x
        acc = 0.0
        for t in range(int(nz[r, 0])):
            k = int(nz[r, 1 + t])
            acc += sel[r, k] * x[k]
        nu[r] = z[r] - acc
    if wrap_yaw:
        nu[2] = wrap_pi(nu[2])
    # S P S' + R:  (S P S')[r, q] = sum_b (S P)[r, b] S[q, b],  (S P)[r, b] = sum_a S[r, a] P[a, b]
    # (a over the non-zero S[r, a], b over the non-zero S[q, b])
    for r in range(m):
        for q in range(m):
            acc = 0.0
            for tb in range(int(nz[q, 0])):
                b = int(nz[q, 1 + tb])
                sp_rb = 0.0
                for ta in range(int(nz[r, 0])):
                    a = int(nz[r, 1 + ta])
                    sp_rb += sel[r, a] * p_mat[a, b]
                acc += sp_rb * sel[q, b]
            s_mat[r, q] = acc
    for r in range(m):
        s_mat[r, r] += r_var
        var[r] = s_mat[r, r]
    # NIS = nu' (S P S' + R)^-1 nu
    return spd_quadratic(s_mat, m, nu, low, tmp)


# ---- one tick's screening of every channel, compiled ----------------------------------------
# The filters' tick kernels (ekf_tick, tskf_tick) link the kernels below into theirs; their
# modules drop their cached kernels when this one changes (jitsupport.cache).
# ChannelCheck.status by code (ABSENT: no batch this tick)
APPLIED, REJECTED, EXCLUDED, SKIPPED, ABSENT = 0, 1, 2, 3, -1
STATUS_NAMES: tuple[ChannelStatus, ...] = ("applied", "rejected", "excluded", "skipped")
# columns of a ChannelSet's layout (int) and noise (float) tables, one row per channel
ROW0, ROW1, WRAP_YAW, IS_ACCEL, PICKS = 0, 1, 2, 3, 4
SAMPLE_VAR, MODEL_VAR, GATE = 0, 1, 2
# columns of a tick's measurement table (TickEstimator._measurements), one row per channel:
# samples averaged (0: no batch), their mean time (s), the measured entries (first m used)
COUNT, TIME, VALUE = 0, 1, 2
MEAS_WIDTH = 5
MAX_CHANNELS = 5  # channels of a filter's set at the most


@refcount_free_kernel
def noise_var(noise: FloatArray, c: int, count: float) -> float:
    """Channel ``c``'s ``R`` (per axis) for the mean of ``count`` samples (``noise``: a
    :class:`ChannelSet`'s)."""
    # R = sigma^2 / n for the mean of n samples (+ model error, not reduced)
    return noise[c, SAMPLE_VAR] / count + noise[c, MODEL_VAR]


@refcount_free_kernel
def on_ground_at(x: FloatArray, ground: FloatArray) -> bool:
    """The ground holds a vehicle in state ``x``: within the ground margin of the ground plane
    with its thrust below its weight. ``ground`` = [ground plane present (0/1), plane z minus
    the margin (m, NED), weight (N)]."""
    if ground[0] == 0.0:
        return False
    # sum(T), left to right as numpy sums four entries
    thrust = x[12] + x[13] + x[14] + x[15]
    return x[Z_INDEX] >= ground[1] and thrust < ground[2]


@njit(cache=True, error_model="numpy", inline="always")
def channel_tables(tables: FloatArray, layout: np.ndarray) -> tuple[FloatArray, FloatArray, int]:
    """A channel set's float tables, packed into one array for the tick kernels
    (:attr:`~fcu.estimation.channels.ChannelSet.tables`): every channel's ``S`` stacked,
    ``sel_stack`` (rows_total, 16), then the ``noise`` table (n_ch, 3), as views; and the
    offset after them (where a filter's own tables follow)."""
    n_ch = layout.shape[0]
    n_sel = layout[n_ch - 1, ROW1] * STATE_DIM
    sel_stack = shaped(tables[:n_sel], (layout[n_ch - 1, ROW1], STATE_DIM))
    noise = shaped(tables[n_sel:n_sel + 3 * n_ch], (n_ch, 3))
    return sel_stack, noise, n_sel + 3 * n_ch


@njit(cache=True, error_model="numpy")
def screen_channels(x: FloatArray, p_mat: FloatArray, meas: FloatArray, sel_stack: FloatArray,
                    layout: np.ndarray, noise: FloatArray, excluded: np.ndarray,
                    on_ground: bool, reject: bool) -> tuple[FloatArray, np.ndarray]:
    """Screen every channel that delivered a batch against the prior ``x``, ``p_mat``
    (module docstring), by :func:`screen_channel` each.

    Parameters
    ----------
    x, p_mat : ndarrays, shapes (16,), (16, 16)
        Prior state and covariance.
    meas : ndarray, shape (n_ch, MEAS_WIDTH)
        The tick's measurement table (:meth:`TickEstimator._measurements`).
    sel_stack, layout, noise : ndarrays
        The channels (:class:`ChannelSet`).
    excluded : ndarray of bool, shape (n_ch,)
        Channels the health monitor excluded (screened, never applied).
    on_ground : bool
        The vehicle is on the ground: the accelerometer is skipped and no outlier rejected.
    reject : bool
        A lone outlier may be rejected.

    Returns
    -------
    screen : ndarray, shape (2 rows_total + 2 n_ch,)
        ``nu = z - S x`` and ``diag(S P S' + R)``, each stacked like ``sel_stack``, then each
        channel's NIS and status code (``APPLIED`` ... ``SKIPPED``, ``ABSENT`` without a
        batch), one array for :meth:`TickEstimator._ticked`.
    status : ndarray of int, shape (n_ch,)
        The status codes again.
    """
    screen = np.empty(2 * sel_stack.shape[0] + 2 * layout.shape[0])
    screen_channels_into(screen, x, p_mat, meas, sel_stack, layout, noise, excluded,
                         on_ground, reject, np.empty(SCREEN_SCRATCH))
    return screen, screen[2 * sel_stack.shape[0] + layout.shape[0]:].astype(np.int64)


@refcount_free_kernel
def screen_channels_into(screen: FloatArray, x: FloatArray, p_mat: FloatArray,
                         meas: FloatArray, sel_stack: FloatArray, layout: np.ndarray,
                         noise: FloatArray, excluded: np.ndarray, on_ground: bool,
                         reject: bool, scratch: FloatArray) -> None:
    """:func:`screen_channels` written into ``screen`` (shape (2 rows_total + 2 n_ch,),
    every entry set; ``scratch``: :data:`SCREEN_SCRATCH` entries); the status codes (as
    floats) are its last ``n_ch`` entries."""
    n_ch = layout.shape[0]
    n_rows = sel_stack.shape[0]
    screen[:] = 0.0
    nis = screen[2 * n_rows:2 * n_rows + n_ch]
    status = screen[2 * n_rows + n_ch:]
    status[:] = ABSENT
    n_outliers = 0
    outlier = -1
    for c in range(n_ch):
        count = meas[c, COUNT]
        if count <= 0.0:
            continue
        i0, i1 = layout[c, ROW0], layout[c, ROW1]
        r_var = noise_var(noise, c, count)
        # nu = z - S x;  diag(S P S' + R);  NIS = nu' (S P S' + R)^-1 nu
        nis[c] = screen_channel_into(
            screen[i0:i1], screen[n_rows + i0:n_rows + i1], sel_stack[i0:i1],
            meas[c, VALUE:VALUE + i1 - i0], x, p_mat, r_var, layout[c, WRAP_YAW] != 0,
            scratch)
        if excluded[c]:
            status[c] = EXCLUDED
        elif on_ground and layout[c, IS_ACCEL] != 0:
            # on the ground the accelerometer feels the ground reaction, not the thrust
            status[c] = SKIPPED
        else:
            status[c] = APPLIED
            if nis[c] > noise[c, GATE]:
                n_outliers += 1
                outlier = c
    if reject and not on_ground and n_outliers == 1:  # a lone outlier is that sensor's fault
        status[outlier] = REJECTED
