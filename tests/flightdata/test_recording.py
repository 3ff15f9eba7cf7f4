"""Rerun recordings (:mod:`flightdata.recording`) of headless flights, read back with rerun's
own tools. Recordings of ground-station flights: tests/gcs/test_gcs_recording.py and
tests/integration/test_gcs_views.py.

Entities, components and timelines come from ``rerun.recording.load_recording(...).schema()``;
row values from the ``rerun rrd print -vvv`` command of the wheel (``python -m rerun_cli``),
since rerun 0.29's Python dataframe queries need the optional ``datafusion`` package. No test
starts a viewer (there is no display here).
"""

from __future__ import annotations

import re
import signal
import subprocess
import sys
import time
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import pytest
import rerun as rr
from rrd_reading import COMMON_ENTITIES, numbers, rerun_receiver, rrd_rows, scalar_series

from flightdata.recording import SIM_TIMELINE, RecordingConfig, rotor_colors, scene_rows
from flightdata.vocabulary import MOTORS
from sim.runner import FlightResult, fly, open_recording
from sim.scenario import Scenario, load_scenario
from sim.scenario_cli import main
from sim.world.fault_types import ActuatorFault

REPO = Path(__file__).resolve().parents[2]
FAULT_AT_S = 6.0  # s, motor 3 loses 30 % while hovering after the take-off (5 s)


def short_scenario() -> Scenario:
    """8 s of the thesis mission (take-off and hover) with one LOE fault in the hover."""
    return replace(load_scenario("lqg_abdob_loe"), name="short", duration_s=8.0,
                   faults=(ActuatorFault(motor=3, kind="loe", start_s=FAULT_AT_S, loe=0.3),))


@dataclass
class Recorded:
    result: FlightResult
    rrd: Path


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory) -> Recorded:
    scenario = short_scenario()
    rrd = tmp_path_factory.mktemp("rec") / "short.rrd"
    recorder = open_recording(scenario, rrd_path=rrd, recording_id="test-short")
    result = fly(scenario, on_tick=recorder.on_tick, on_event=recorder.on_event)
    recorder.close()
    return Recorded(result, rrd)


# ---------------------------------------------------------------------- the tests
EXPECTED_ENTITIES = {
    **COMMON_ENTITIES,
    "/world/mission": "Points3D:positions",
    "/world/wind": "Arrows3D:vectors",
    **{f"/plots/position/{a}/estimate": "Scalars:scalars" for a in "xyz"},
}


def test_recording_has_the_documented_entities_and_the_sim_time_timeline(
        recorded: Recorded) -> None:
    recording = rr.recording.load_recording(recorded.rrd)
    schema = recording.schema()
    columns = {(c.entity_path, c.component) for c in schema.component_columns()}
    missing = {kv for kv in EXPECTED_ENTITIES.items() if kv not in columns}
    assert not missing
    timelines = {c.name for c in schema.index_columns()}
    assert SIM_TIMELINE in timelines
    assert recording.application_id() == "quadftc"
    assert recording.recording_id() == "test-short"


def test_truth_series_has_one_row_per_tick_equal_to_the_flight_log(recorded: Recorded) -> None:
    log = recorded.result.log
    for i, axis in enumerate("xyz"):
        t, values = scalar_series(recorded.rrd, f"/plots/position/{axis}/truth")
        assert len(t) == len(log.time_s)
        # the timeline holds whole nanoseconds, rounded: within half a nanosecond
        np.testing.assert_allclose(t, log.time_s, rtol=0.0, atol=0.5e-9)
        # f64 scalars are printed in round-trip form: exactly the logged values
        np.testing.assert_array_equal(values, log.pos_ned[:, i])


def test_reference_and_error_series_cover_the_flying_ticks_only(recorded: Recorded) -> None:
    log = recorded.result.log
    fly_mask = log.flying
    assert 0 < np.count_nonzero(fly_mask) < len(fly_mask)  # on the ground at first
    t, ref_z = scalar_series(recorded.rrd, "/plots/position/z/ref")
    np.testing.assert_allclose(t, log.time_s[fly_mask], rtol=0.0, atol=0.5e-9)
    np.testing.assert_array_equal(ref_z, log.ref_pos_ned[fly_mask, 2])
    _, err_x = scalar_series(recorded.rrd, "/plots/error/x")
    np.testing.assert_array_equal(err_x, log.ref_pos_ned[fly_mask, 0] - log.pos_ned[fly_mask, 0])
    _, roll = scalar_series(recorded.rrd, "/plots/attitude/roll/truth")
    np.testing.assert_allclose(roll, np.degrees(log.euler_rad[:, 0]), rtol=0, atol=1e-12)


def test_pwm_and_effectiveness_series_equal_the_flight_log(recorded: Recorded) -> None:
    log = recorded.result.log
    for j, m in enumerate(MOTORS):
        _, pwm = scalar_series(recorded.rrd, f"/plots/pwm/{m}")
        np.testing.assert_array_equal(pwm, log.pwm[:, j])
        _, est = scalar_series(recorded.rrd, f"/plots/loe/{m}/estimate")
        np.testing.assert_array_equal(est, log.loe_estimate[j])
    t, injected = scalar_series(recorded.rrd, "/plots/loe/3/true")
    np.testing.assert_array_equal(injected, log.loe_injected[:, 2])
    assert np.all(injected[t < FAULT_AT_S] == 0.0) and np.all(injected[t >= FAULT_AT_S] == 0.3)


def test_vehicle_pose_is_the_truth_at_the_scene_rate(recorded: Recorded) -> None:
    log = recorded.result.log
    every = round(recorded.result.scenario.autopilot.loop_rate_hz
                  / RecordingConfig().scene_rate_hz)
    assert every == 4  # 100 Hz loop, 25 Hz scene
    rows = rrd_rows(recorded.rrd, "/world/vehicle")
    t = np.array([r[0] for r in rows])
    np.testing.assert_allclose(t, log.time_s[::every], rtol=0.0, atol=0.5e-9)
    translation = np.array([numbers(r["Transform3D:translation"]) for _, r in rows])
    # float32 on the wire: 1e-6 m is ten float32 steps at the metre scale of this flight
    np.testing.assert_allclose(translation, log.pos_ned[::every], rtol=0.0, atol=1e-6)
    quat_xyzw = np.array([numbers(r["Transform3D:quaternion"]) for _, r in rows])
    np.testing.assert_allclose(np.linalg.norm(quat_xyzw, axis=1), 1.0, atol=1e-6)


def test_rotor_colours_follow_the_pwm_and_turn_red_on_the_faulty_motor(
        recorded: Recorded) -> None:
    log = recorded.result.log
    rows = rrd_rows(recorded.rrd, "/world/vehicle/rotors")
    rows = [(t, r) for t, r in rows if "Cylinders3D:colors" in r]  # not the label updates
    packed = np.array([numbers(r["Cylinders3D:colors"]) for _, r in rows], dtype=np.uint64)
    rgb = np.stack([(packed >> 24) & 255, (packed >> 16) & 255, (packed >> 8) & 255], axis=-1)
    t = np.array([r[0] for r in rows])
    np.testing.assert_allclose(t, log.time_s[::4], rtol=0.0, atol=0.5e-9)
    faulted = log.loe_injected[::4] > 0.0
    expected = rotor_colors(log.pwm[::4].reshape(-1), 0.05, faulted.reshape(-1)).reshape(-1, 4, 3)
    np.testing.assert_array_equal(rgb, expected)
    after = t >= FAULT_AT_S
    red = rgb[after, 2]
    assert np.all(red[:, 0] > 2 * red[:, 1]) and np.all(red[:, 0] > 2 * red[:, 2])
    healthy = rgb[:, [0, 1, 3]]
    assert not np.any(healthy[..., 0] > 2 * healthy[..., 1])


def test_rotor_colour_ramps() -> None:
    low, high = rotor_colors(np.array([0.0, 0.05]), 0.05, np.array([False, False]))
    assert low[2] > low[0] and low[2] > low[1]  # PWM 0: blue
    assert high[0] > high[2] and high[1] > high[2]  # full power: yellow
    f_low, f_high = rotor_colors(np.array([0.0, 0.05]), 0.05, np.array([True, True]))
    assert f_low[0] > 0 and f_low[1] == f_low[2] == 0  # faulted: red, darker at low PWM
    assert f_high[0] > f_low[0]


def test_scene_rows_are_one_per_slot_and_do_not_depend_on_later_samples() -> None:
    t = np.r_[0.0, 0.0, np.arange(1, 301) * 0.01]  # paused at 0, then 100 Hz
    rows = scene_rows(t, 25.0)
    np.testing.assert_allclose(t[rows], np.arange(0, 76) * 0.04, atol=1e-12)  # every 40 ms
    np.testing.assert_array_equal(scene_rows(t[:150], 25.0), rows[rows < 150])
    # slots count from the first sample: a 100 Hz tick from 0.01 s draws every fourth
    ticks = np.arange(1, 301) * 0.01
    np.testing.assert_array_equal(scene_rows(ticks, 25.0), np.arange(0, 300, 4))


def test_every_event_is_in_the_text_log(recorded: Recorded) -> None:
    rows = rrd_rows(recorded.rrd, "/events")
    assert len(rows) == len(recorded.result.events)
    texts = [r["TextLog:text"] for _, r in rows]
    injected = [(t, r) for t, r in rows if "[sim] fault started: motor 3" in r["TextLog:text"]]
    assert len(injected) == 1 and injected[0][0] == pytest.approx(FAULT_AT_S, abs=1e-9)
    assert injected[0][1]["TextLog:level"] == "[WARN]"
    assert any("[autopilot] armed" in text for text in texts)


def test_recording_does_not_change_the_flight(recorded: Recorded) -> None:
    plain = fly(recorded.result.scenario)
    np.testing.assert_array_equal(plain.log.pos_ned, recorded.result.log.pos_ned)
    np.testing.assert_array_equal(plain.log.pwm, recorded.result.log.pwm)
    assert plain.events == recorded.result.events


# ---------------------------------------------------------------------- the command
def _write_short_toml(path: Path, duration_s: float) -> Path:
    path.write_text(f'''name = "short"
duration_s = {duration_s}
seed = 1
[autopilot]
dob = "abdob"
[[faults]]
motor = 3
kind = "loe"
start_s = {FAULT_AT_S}
loe = 0.3
''')
    return path


@pytest.mark.slow  # a whole flight or figure set: make test only
def test_run_writes_recording_figures_and_a_final_progress_line(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    toml = _write_short_toml(tmp_path / "short.toml", 8.0)
    rrd, figs = tmp_path / "out" / "short.rrd", tmp_path / "figs"
    assert main(["run", str(toml), "--rrd", str(rrd), "--figures", str(figs)]) == 0
    out, err = capsys.readouterr()
    assert f"recording: {rrd}" in out
    # stderr is not a terminal here: only the final line, no carriage-return rewrites
    assert "\r" not in err
    assert re.search(r"short  t =   8\.0 / 8\.0 s +[\d.]+x real time  AUTO", err)
    # then one line per slow step, saying what it does
    assert err.splitlines()[-2:] == [
        f"ftc-scenario: writing the recording {rrd}...",
        f"ftc-scenario: writing figures (5 kinds, PNG and PDF) in {figs}..."]
    t, _ = scalar_series(rrd, "/plots/pwm/1")
    assert len(t) == 800
    assert len(list(figs.glob("*.png"))) == 5 and len(list(figs.glob("*.pdf"))) == 5


@pytest.mark.slow  # a whole flight or figure set: make test only
def test_ctrl_c_in_a_run_keeps_the_flight_so_far(tmp_path: Path,
                                                 monkeypatch: pytest.MonkeyPatch,
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    from sim.progress import ProgressLine

    real_on_tick = ProgressLine.on_tick

    def interrupt_at_3_s(self: ProgressLine, world: object, autopilot: object) -> None:
        real_on_tick(self, world, autopilot)  # type: ignore[arg-type]
        if self._sim_s >= 3.0 - 1e-9:
            raise KeyboardInterrupt

    monkeypatch.setattr(ProgressLine, "on_tick", interrupt_at_3_s)
    toml = _write_short_toml(tmp_path / "short.toml", 8.0)
    rrd, figs, js = tmp_path / "short.rrd", tmp_path / "figs", tmp_path / "m.json"
    code = main(["run", str(toml), "--rrd", str(rrd), "--figures", str(figs), "--json", str(js)])
    assert code == 130
    _, err = capsys.readouterr()
    assert "(interrupted)" in err and "interrupted at t = 3.00 s" in err
    t, _ = scalar_series(rrd, "/plots/position/x/truth")
    assert len(t) == 300 and t[-1] == pytest.approx(3.0, abs=1e-9)
    assert js.exists() and len(list(figs.glob("*.png"))) == 5


@pytest.mark.slow
def test_sigint_ends_a_long_run_with_status_130_and_a_readable_recording(
        tmp_path: Path) -> None:
    toml = _write_short_toml(tmp_path / "long.toml", 600.0)
    rrd = tmp_path / "long.rrd"
    proc = subprocess.Popen(
        [sys.executable, "-m", "sim.scenario_cli", "run", str(toml), "--rrd", str(rrd)],
        cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    try:
        deadline = time.monotonic() + 120.0
        # the blueprint and static entities take ~150 kB, each second of flight ~150 kB more:
        # past 600 kB a few seconds have been flown
        while time.monotonic() < deadline and not (rrd.exists() and rrd.stat().st_size > 600_000):
            time.sleep(0.2)
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=120)
    finally:
        proc.kill()
    assert proc.returncode == 130, err
    assert "interrupted at t =" in err
    t, _ = scalar_series(rrd, "/plots/position/x/truth")
    assert 1.0 <= t[-1] < 600.0
    np.testing.assert_allclose(np.diff(t), 0.01, atol=1e-9)  # no tick lost before the end


def test_nan_injected_effectiveness_is_recorded_as_nan(tmp_path: Path) -> None:
    scenario = replace(short_scenario(), duration_s=2.0,
                       faults=(ActuatorFault(motor=2, kind="lock", start_s=1.0),))
    rrd = tmp_path / "lock.rrd"
    recorder = open_recording(scenario, rrd_path=rrd)
    fly(scenario, on_tick=recorder.on_tick, on_event=recorder.on_event)
    recorder.close()
    t, injected = scalar_series(rrd, "/plots/loe/2/true")
    # lock: the output no longer scales with the command, no gamma describes it (NaN)
    assert np.all(np.isnan(injected[t >= 1.0])) and np.all(injected[t < 1.0] == 0.0)
    _, healthy = scalar_series(rrd, "/plots/loe/1/true")
    assert not np.any(np.isnan(healthy))


def test_live_stream_reaches_a_rerun_grpc_receiver(tmp_path: Path) -> None:
    """The --rerun path without a viewer: rerun's own headless receiver saves what arrives."""
    saved = tmp_path / "live.rrd"
    with rerun_receiver(saved) as url:
        scenario = replace(short_scenario(), duration_s=2.0)
        recorder = open_recording(scenario, connect_url=url)
        result = fly(scenario, on_tick=recorder.on_tick, on_event=recorder.on_event)
        recorder.close()
        deadline = time.monotonic() + 30.0
        while time.monotonic() < deadline:
            if saved.exists() and len(rrd_rows(saved, "/plots/pwm/1")) == 200:
                break
            time.sleep(0.5)
    _, pwm = scalar_series(saved, "/plots/pwm/1")
    np.testing.assert_array_equal(pwm, result.log.pwm[:, 0])
