"""Chapter 7 reproduced headless: what the thesis's results require of the whole stack.

Each shipped scenario is flown once (seeded, wind and sensor noise on) by the headless runner,
the same loop the vehicle process runs, and its metrics are checked against physics and the
orderings the thesis reports (../shared/reference/thesis-notes.md, "what reproduce means").
"""

from __future__ import annotations

from dataclasses import replace

import pytest
from flown import metrics

from fcu.autopilot import Autopilot
from flightdata.metrics import attitude_rms_norm
from flightdata.thesis import thesis_tables
from sim.runner import fly
from sim.scenario import load_scenario

pytestmark = pytest.mark.slow

TABLES = thesis_tables()
AIRFRAME = TABLES["airframe"]
HOVER_EFFORT = AIRFRAME["mass"] * AIRFRAME["gravity"] / AIRFRAME["thrust_gain"]  # m g / K


def test_baseline_tracks_to_a_centimetre_at_hover_effort() -> None:
    m = metrics("baseline")
    assert m["outcome"]["kind"] == "landed", m["outcome"]
    for axis in ("x", "y", "z"):
        assert m["rms"][axis] <= 0.01, axis  # issue 3: RMS position error <= 1 cm per axis
        assert m["max"][axis] <= 0.05, axis  # issue 3: max position error <= 5 cm
    # the effort of a flight at constant mass is the hover effort m g / K (2 %: the
    # accelerations of the square and the drag of the wind add a little)
    assert m["control_effort"] == pytest.approx(HOVER_EFFORT, rel=0.02)


def test_baseline_raises_no_fault_detection() -> None:
    assert metrics("baseline")["detections"] == []


@pytest.mark.parametrize("name", ["lqg_loe", "lqg_abdob_loe"])
def test_lqg_survives_table_7_3_faults(name: str) -> None:
    m = metrics(name)
    assert m["outcome"]["kind"] == "landed", m["outcome"]
    assert m["rms"]["z"] <= 0.05  # issue 3: the altitude dips at each fault and recovers
    for axis in ("x", "y", "z"):
        assert m["max"][axis] < 0.15, axis
    # a weakened motor must be driven harder: more effort than the fault-free flight
    assert m["control_effort"] > metrics("baseline")["control_effort"]


@pytest.mark.parametrize("dob", ["pd_vbdob_loe", "pd_abdob_loe"])
def test_each_dob_cuts_pd_attitude_error_by_30_percent(dob: str) -> None:
    pd_alone = attitude_rms_norm(metrics("pd_loe")["rms"])
    with_dob = attitude_rms_norm(metrics(dob)["rms"])
    assert with_dob <= 0.7 * pd_alone, (with_dob, pd_alone)


def test_lqg_beats_pd_with_ekf_feedback() -> None:
    # thesis section 7.2: LQG tracks better than PD under the same faults
    lqg, pd = (attitude_rms_norm(metrics(name)["rms"]) for name in ("lqg_loe", "pd_loe"))
    assert lqg < pd


def test_tskf_estimates_the_table_6_1_step_profile() -> None:
    m = metrics("tskf_step")
    convergence = m["loe_estimate"]["convergence"]
    assert {c["motor"] for c in convergence} == {1, 3, 4}
    for c in convergence:
        # issue 3: within 0.05 of the truth within 3 s of the fault, and stays there
        assert c["settled_after_s"] is not None and c["settled_after_s"] <= 3.0, c
    assert m["loe_estimate"]["final"][1] < 0.05  # motor 2 is healthy


@pytest.mark.parametrize("case", [f"case{i}" for i in range(1, 9)])
def test_table_7_11_cases_finish_without_a_crash(case: str) -> None:
    outcome = metrics(case)["outcome"]
    assert outcome["kind"] == "landed", outcome  # simulator truth: down, gently, disarmed


@pytest.mark.parametrize("case", ["case1", "case2", "case7"])
def test_mass_drop_effort_matches_table_7_12(case: str) -> None:
    thesis = TABLES["cases"][case.removeprefix("case")]["effort"]
    # issue 3: within 3 % of Table 7.12 (physics fixes it: m g / K before and after 22 s)
    assert metrics(case)["control_effort"] == pytest.approx(thesis, rel=0.03)


@pytest.mark.parametrize("name", ["lqg_loe", "tskf_step"])
def test_faults_of_15_percent_or_more_are_detected_within_3_s(name: str) -> None:
    m = metrics(name)
    scenario = load_scenario(name)
    for fault in scenario.faults:
        if getattr(fault, "loe", 0.0) < 0.15:
            continue
        hits = [d["time_s"] - fault.start_s for d in m["detections"]
                if d["kind"] in ("loe", "motor_lost") and d["motor"] == fault.motor
                and d["time_s"] >= fault.start_s]
        assert hits and min(hits) <= 3.0, (fault, m["detections"])


def test_a_declared_motor_blocks_arming_with_its_latest_estimated_loss() -> None:
    # the blocker is rewritten only when the whole per cent it names changes: at every tick
    # it must still read what the detector's latest estimate says
    percents = []

    def check(world: object, ap: Autopilot) -> None:
        active, loe = ap.detector.active, ap.detector.loe
        expected = tuple("; ".join(
            f"motor {m} detected failed (lost about {round(100 * float(loe[m - 1]))} %): "
            "restart the autopilot to clear" for m in active) for _ in active[:1])
        assert ap.navigator.arming_blockers == expected, world
        status = ap.status
        assert status is not None
        assert status.fault_detected == tuple(m in active for m in (1, 2, 3, 4)), world
        if active:
            percents.append(round(100 * float(loe[active[0] - 1])))

    fly(replace(load_scenario("lqg_abdob_loe"), duration_s=45.0), on_tick=check)
    assert len(set(percents)) >= 2  # declared, and the estimate moved while it was
