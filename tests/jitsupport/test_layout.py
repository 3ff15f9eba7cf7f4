"""The layout helper, and the layouts of the compiled filters and the control chain."""

from __future__ import annotations

from pathlib import Path

import pytest

from fcu.control import chain
from fcu.estimation import ekf, tskf_kernel
from fcu.monitoring import rotor_watch_kernel, sensor_health
from jitsupport.layout import LANES, Layout, aligned_zeros


def test_fields_follow_each_other_in_declaration_order() -> None:
    lay = Layout("demo")
    assert lay.field("a", 3) == 0
    assert lay.field("b", 16) == 3
    assert lay.field("c", 1) == 19
    assert lay.size == 20
    assert [(f.name, f.start, f.stop) for f in lay.fields] == [
        ("a", 0, 3), ("b", 3, 19), ("c", 19, 20)]


def test_a_field_is_found_by_name() -> None:
    lay = Layout("demo")
    lay.field("x", 2)
    lay.field("P", 4)
    assert (lay["P"].start, lay["P"].size, lay["P"].stop) == (2, 4, 6)


def test_a_nested_record_is_one_field_whose_own_fields_are_found_by_dotted_name() -> None:
    inner = Layout("inner")
    inner.field("a", 3)
    inner.field("b", 2)
    outer = Layout("outer")
    outer.field("x", 4)
    assert outer.nest("rec", inner) == 4
    outer.field("y", 1)
    assert [f.name for f in outer.fields] == ["x", "rec", "y"]
    assert (outer["rec"].size, outer["rec.a"].start, outer["rec.b"].start) == (5, 4, 7)
    assert outer["y"].start == 9
    assert chain.OUT["reference.rate_rad_s"].start == chain.OUT_REF + 3


@pytest.mark.parametrize("call", [lambda lay: lay.field("a", 1),
                                  lambda lay: lay.field("b", -1)])
def test_bad_fields_are_refused_with_the_layout_and_field_named(call: object) -> None:
    lay = Layout("demo layout")
    lay.field("a", 1)
    with pytest.raises(ValueError, match="demo layout"):
        call(lay)  # type: ignore[operator]


def test_an_unknown_field_names_the_fields_there_are() -> None:
    lay = Layout("demo")
    lay.field("x", 1)
    with pytest.raises(KeyError, match="fields: x"):
        lay["y"]


def test_aligned_zeros_start_on_a_cache_line() -> None:
    for n in (1, 7, 100, 5527):
        z = aligned_zeros(n)
        assert z.shape == (n,) and not z.any()
        assert z.ctypes.data % (8 * LANES) == 0


@pytest.mark.parametrize("layout", [ekf.WORK, ekf.SCRATCH, ekf.CONSTANTS, ekf.BUFFER,
                                    tskf_kernel.WORK, tskf_kernel.SCRATCH, tskf_kernel.MODEL,
                                    tskf_kernel.BUFFER, chain.OUT, chain.SCRATCH,
                                    sensor_health.ROW, rotor_watch_kernel.STATE,
                                    rotor_watch_kernel.PARAMS], ids=lambda lay: lay.name)
def test_product_layouts_tile_their_array_without_gap_or_overlap(layout: Layout) -> None:
    end = 0
    for f in layout.fields:
        assert f.start == end, f"{layout.name}: {f.name} starts at {f.start}, not {end}"
        end = f.stop
    assert end == layout.size


def test_row_updated_matrices_start_on_a_vector_boundary() -> None:
    """The covariance matrices the row kernels update whole rows of (small_matrix) start at
    a multiple of LANES entries of an aligned buffer: a field of odd size declared before
    them would make every row load straddle two cache lines."""
    starts = {"EKF P": ekf.B_WORK + ekf.WORK["P"].start,
              "EKF P prior": ekf.B_WORK + ekf.WORK["P_prior"].start,
              "TSKF P^x": tskf_kernel.B_WORK + tskf_kernel.WORK["P_x"].start,
              "TSKF P^x prior": (tskf_kernel.B_WORK + tskf_kernel.W_PRIOR
                                 + tskf_kernel.WORK["P_x"].start)}
    assert {k: v % LANES for k, v in starts.items()} == dict.fromkeys(starts, 0)


def test_the_tskf_priors_mirror_the_posteriors() -> None:
    """tskf_tick copies the first W_PRIOR entries (x_bar, P^x, P^gamma, V) onto the priors."""
    work = tskf_kernel.WORK
    assert work["priors"].size == work["priors"].start == sum(
        work[name].size for name in ("x_bar", "P_x", "P_gamma", "V"))


def test_the_chain_output_holds_the_crash_measures_in_crash_check_order() -> None:
    from fcu.monitoring import crash_check
    names = [f.name for f in chain.OUT.fields]
    first = names.index("alt_m")
    assert names[first:first + crash_check.MEASURES_SIZE] == [
        "alt_m", "vel_down_m_s", "speed_m_s", "lean_rad", "att_error_rad", "collective"]
    assert (crash_check.ALT, crash_check.VEL_DOWN, crash_check.SPEED, crash_check.LEAN,
            crash_check.ATTITUDE_ERROR, crash_check.COLLECTIVE) == tuple(range(6))


DESIGN = Path(__file__).resolve().parents[2] / "docs" / "design.md"


@pytest.mark.parametrize("label, layout", [("`ekf.WORK`", ekf.WORK), ("`ekf.BUFFER`", ekf.BUFFER),
                                           ("`tskf_kernel.WORK`", tskf_kernel.WORK),
                                           ("`tskf_kernel.BUFFER`", tskf_kernel.BUFFER),
                                           ("`rotor_watch_kernel.STATE`",
                                            rotor_watch_kernel.STATE)])
def test_design_doc_lists_each_state_layout_as_the_code_declares_it(label: str,
                                                                    layout: Layout) -> None:
    row = next(line for line in DESIGN.read_text().splitlines() if line.startswith(f"| {label}"))
    listed = row.split("|")[3]
    for f in layout.fields:
        assert f"{f.name} {f.size}" in listed, f"{label}: {f.name} {f.size} not in {listed!r}"


def test_design_doc_lists_every_field_of_the_control_tick_output() -> None:
    text = DESIGN.read_text()
    section = text[text.index("The control tick's output record"):]
    documented = {line.split("|")[1].strip() for line in section.splitlines()
                  if line.startswith("| `")}
    from fcu.monitoring import crash_check
    measures = [f.name for f in chain.OUT.fields][7:7 + crash_check.MEASURES_SIZE]
    expected = {f"`{f.name}`" for f in chain.OUT.fields if f.name not in measures}
    assert expected | {f"`{measures[0]}` ... `{measures[-1]}`"} == documented
