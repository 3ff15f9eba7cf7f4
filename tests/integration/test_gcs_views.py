"""``ftc-gcs fly --rerun URL --rrd --figures --report`` on one real flight, read back.

One flight (module fixture): the thesis mission at speed-up 10, TSKF + LQG + AbDOB, motor 3
losing 30 % at mission +10 s, streamed live to rerun's headless gRPC receiver (``rerun
--save``, no viewer: there is no display) and written afterwards from the .tlog. Recordings
are read back with rerun's own tools: ``rerun.recording.load_recording(...).schema()`` for
entities and timelines, ``rerun rrd print -vvv`` for row values (tests/rrd_reading.py).
Figures are checked through matplotlib objects. Every expected value comes from
:meth:`gcs.analysis.FlightAnalyzer.series` of the .tlog, the arrays behind the table.
"""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import rerun as rr
from rrd_reading import COMMON_ENTITIES, numbers, rerun_receiver, rrd_rows, scalar_series

from flightdata.figures import attitude_series, figure_kinds, make_figures, position_series
from flightdata.geometry import quats_from_euler
from flightdata.recording import SIM_TIMELINE, rotor_colors, scene_rows
from flightdata.series import FlightSeries
from gcs.analysis import analyze_tlog, replay_tlog
from gcs.cli import main
from gcs.table import format_report

ROOT = Path(__file__).resolve().parents[2]
FAULT_AT_S = 10.0  # s after the mission start: motor 3 loses 30 % in the first leg
FIGURE_KINDS = figure_kinds()
# speed-up 10, not more: the station streams every SIM_STATE live to rerun as it records, and
# at 20 (2000 SIM_STATE a wall second) a station starved of CPU by a loaded machine falls
# behind until its socket overflows (a fifth of the flight lost once in a full parallel run)
SPEEDUP = 10
FLIGHT_WALL_S = 300.0  # s: ~15 s at speed-up 10; generous for a loaded machine

pytestmark = pytest.mark.slow


# ---------------------------------------------------------------------- the flight
@pytest.fixture(scope="module")
def flight(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    out = tmp_path_factory.mktemp("gcs_recording")
    live = out / "live.rrd"
    with rerun_receiver(live, settle_s=0.5) as url:
        proc = subprocess.run(
            [sys.executable, "-m", "gcs", "fly", "--spawn-vehicle", "--speedup", str(SPEEDUP),
             "--seed", "1", "--scenario", "tskf_lqg_abdob_loe", "--estimator", "tskf",
             "--fault", f"3:0.30@{FAULT_AT_S:g}", "--tlog", str(out / "f.tlog"),
             "--rrd", str(out / "f.rrd"), "--figures", str(out / "figs"),
             "--report", str(out / "report"), "--rerun", url, "--quiet"],
            cwd=ROOT, capture_output=True, text=True, timeout=FLIGHT_WALL_S,
            stdin=subprocess.DEVNULL)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    tlog = out / "f.tlog"
    analyzer = replay_tlog(tlog)
    return {"dir": out, "stdout": proc.stdout, "tlog": tlog, "rrd": out / "f.rrd",
            "live": live, "analyzer": analyzer, "series": analyzer.series(),
            "report": analyze_tlog(tlog)}


EXPECTED_ENTITIES = COMMON_ENTITIES  # no wind, no estimate, no mission in telemetry


@pytest.mark.parametrize("which", ["rrd", "live"])
def test_recordings_have_the_entities_and_the_sim_time_timeline(flight: dict[str, Any],
                                                                which: str) -> None:
    recording = rr.recording.load_recording(flight[which])
    schema = recording.schema()
    columns = {(c.entity_path, c.component) for c in schema.component_columns()}
    assert not {kv for kv in EXPECTED_ENTITIES.items() if kv not in columns}
    assert SIM_TIMELINE in {c.name for c in schema.index_columns()}
    assert recording.application_id() == "quadftc"


def test_fly_says_where_the_views_went(flight: dict[str, Any]) -> None:
    out = flight["dir"]
    for line in (f"recording: {out / 'f.rrd'}", f"figures: {out / 'figs'}",
                 f"report: {out / 'report' / 'report.md'}"):
        assert line in flight["stdout"]


def test_truth_reference_and_errors_are_the_aligned_telemetry(flight: dict[str, Any]) -> None:
    s: FlightSeries = flight["series"]
    rrd = flight["rrd"]
    t, x = scalar_series(rrd, "/plots/position/x/truth")
    assert len(t) == len(s.time_s) > 5000  # every SIM_STATE of a ~60 s flight at 100 Hz
    # the timeline holds whole nanoseconds, rounded: within half a nanosecond
    np.testing.assert_allclose(t, s.time_s, rtol=0.0, atol=0.5e-9)
    np.testing.assert_array_equal(x, s.pos_ned[:, 0])  # f64 scalars print round-trip
    t_ref, ref_z = scalar_series(rrd, "/plots/position/z/ref")
    np.testing.assert_allclose(t_ref, s.time_s[s.flying], rtol=0.0, atol=0.5e-9)
    np.testing.assert_array_equal(ref_z, s.ref_pos_ned[s.flying, 2])
    report = flight["report"]
    assert len(t_ref) == report.samples
    for axis in ("x", "y", "z", "roll", "pitch", "yaw"):
        _, err = scalar_series(rrd, f"/plots/error/{axis}")
        # the table's RMS over the recorded error rows (summation order: 1e-12 relative)
        assert np.sqrt(np.mean(err ** 2)) == pytest.approx(report.rms[axis], rel=1e-12)
        assert np.max(np.abs(err)) == pytest.approx(report.max[axis], rel=1e-12)


def test_pwm_and_effectiveness_series_are_the_telemetry(flight: dict[str, Any]) -> None:
    s: FlightSeries = flight["series"]
    rrd = flight["rrd"]
    for j in range(4):
        t, pwm = scalar_series(rrd, f"/plots/pwm/{j + 1}")
        np.testing.assert_allclose(t, s.pwm_time_s, rtol=0.0, atol=0.5e-9)
        np.testing.assert_array_equal(pwm, s.pwm[:, j])
    t, est = scalar_series(rrd, "/plots/loe/3/estimate")
    np.testing.assert_allclose(t, s.loe_estimate_time_s[2], rtol=0.0, atol=0.5e-9)
    np.testing.assert_array_equal(est, s.loe_estimate[2])
    assert est[-1] == pytest.approx(0.30, abs=0.03)  # the TSKF found the 30 % (its noise)
    t, injected = scalar_series(rrd, "/plots/loe/3/true")
    start = flight["analyzer"].mission_start_s
    assert start is not None
    onset = start + FAULT_AT_S
    # the injection lands on the tick the command is handled (within one 10 ms tick)
    assert np.all(injected[t < onset - 1e-9] == 0.0)
    assert np.all(injected[t >= onset + 0.0101] == pytest.approx(0.30))
    _, healthy = scalar_series(rrd, "/plots/loe/1/true")
    assert np.all(healthy == 0.0)


def test_vehicle_pose_and_rotor_colours_follow_the_telemetry(flight: dict[str, Any]) -> None:
    s: FlightSeries = flight["series"]
    rows = rrd_rows(flight["rrd"], "/world/vehicle")
    scene = scene_rows(s.time_s, 25.0)
    t = np.array([r[0] for r in rows])
    np.testing.assert_allclose(t, s.time_s[scene], rtol=0.0, atol=0.5e-9)
    translation = np.array([numbers(r["Transform3D:translation"]) for _, r in rows])
    # float32 on the wire: 1e-6 m is ten float32 steps at the metre scale of this flight
    np.testing.assert_allclose(translation, s.pos_ned[scene], rtol=0.0, atol=1e-6)
    quat_xyzw = np.array([numbers(r["Transform3D:quaternion"]) for _, r in rows])
    expected_q = quats_from_euler(s.euler_rad[scene])[:, [1, 2, 3, 0]]
    np.testing.assert_allclose(quat_xyzw, expected_q, rtol=0.0, atol=1e-6)  # float32
    rotor = [(tr, r) for tr, r in rrd_rows(flight["rrd"], "/world/vehicle/rotors")
             if "Cylinders3D:colors" in r]  # not the label updates
    packed = np.array([numbers(r["Cylinders3D:colors"]) for _, r in rotor], dtype=np.uint64)
    rgb = np.stack([(packed >> 24) & 255, (packed >> 16) & 255, (packed >> 8) & 255], axis=-1)
    i_pwm = np.searchsorted(s.pwm_time_s, s.time_s[scene] + 1e-9, side="right") - 1
    pwm = np.where((i_pwm >= 0)[:, None], s.pwm[np.maximum(i_pwm, 0)], 0.0)
    faulted = s.loe_injected[scene] > 0.0
    expected = rotor_colors(pwm.reshape(-1), 0.05, faulted.reshape(-1)).reshape(-1, 4, 3)
    np.testing.assert_array_equal(rgb, expected)
    red = rgb[faulted[:, 2], 2]  # motor 3 while its fault is in force: red
    assert len(red) > 100 and np.all(red[:, 0] > 2 * red[:, 1])
    labels = [r["Cylinders3D:labels"]
              for _, r in rrd_rows(flight["rrd"], "/world/vehicle/rotors")
              if "Cylinders3D:labels" in r]
    assert any("3 LOE 0.30" in text for text in labels)


def test_events_are_in_the_text_log(flight: dict[str, Any]) -> None:
    s: FlightSeries = flight["series"]
    rows = rrd_rows(flight["rrd"], "/events")
    assert len(rows) == len(s.events)
    texts = [r["TextLog:text"][1:-1] for _, r in rows]  # printed as [text]
    inject = [(t, r) for (t, r), text in zip(rows, texts, strict=True)
              if text.startswith("[INJECT] motor 3")]
    injected_at_s = flight["analyzer"].injections[0].time_s
    assert len(inject) == 1 and inject[0][0] == pytest.approx(injected_at_s, abs=1e-9)
    assert inject[0][1]["TextLog:level"] == "[WARN]"
    detect = [t for (t, _), text in zip(rows, texts, strict=True)
              if text.startswith("[DETECT] motor 3")]
    assert detect == [pytest.approx(flight["report"].detections[0].time_s, abs=1e-9)]
    for words in ("[MODE] mode AUTO", "[ARM] armed", "[ARM] disarmed", "mission complete"):
        assert any(words in text for text in texts), words


def test_the_live_stream_carries_the_same_flight(flight: dict[str, Any]) -> None:
    s: FlightSeries = flight["series"]
    live = flight["live"]
    t, pwm = scalar_series(live, "/plots/pwm/1")
    np.testing.assert_array_equal(pwm, s.pwm[:, 0])  # every sample, as received
    t, x = scalar_series(live, "/plots/position/x/truth")
    np.testing.assert_allclose(t, s.time_s, rtol=0.0, atol=0.5e-9)
    # live north/east are anchored to the geodetic mean of the samples so far (docstring of
    # gcs.cli._live_recorder): within a few mm of the final ones
    np.testing.assert_allclose(x, s.pos_ned[:, 0], rtol=0.0, atol=5e-3)
    t_ref, _ = scalar_series(live, "/plots/position/z/ref")
    np.testing.assert_allclose(t_ref, s.time_s[s.flying], rtol=0.0, atol=0.5e-9)
    assert len(rrd_rows(live, "/events")) == len(s.events)


def test_figures_are_written_and_the_report_embeds_them(flight: dict[str, Any]) -> None:
    figs = flight["dir"] / "figs"
    assert sorted(p.name for p in figs.iterdir()) == sorted(
        f"{k}.{fmt}" for k in FIGURE_KINDS for fmt in ("png", "pdf"))
    root = flight["dir"] / "report"
    md = (root / "report.md").read_text()
    assert format_report(flight["report"], title="flight") in md  # the printed table
    images = re.findall(r"!\[[^\]]*\]\(([^)]+)\)", md)
    assert images == [f"figures/{k}.png" for k in FIGURE_KINDS]
    for rel in images:
        path = root / rel
        assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        assert path.with_suffix(".pdf").read_bytes()[:5] == b"%PDF-"
    assert "| 3 |" in md  # the detection row


def test_figure_lines_are_the_analysis_arrays(flight: dict[str, Any]) -> None:
    s: FlightSeries = flight["series"]
    figs = make_figures(s)
    assert list(figs) == list(FIGURE_KINDS)

    def lines(ax: Any) -> dict[str, Any]:
        return {line.get_label(): line for line in ax.get_lines()
                if not line.get_label().startswith("_")}

    axes = figs["xyz"].axes
    assert [ax.get_ylabel() for ax in axes] == ["X = x north (m)", "Y = y east (m)",
                                                 "Z = -z altitude (m)", "e_X (m)", "e_Y (m)",
                                                 "e_Z (m)"]
    for col, (ref, truth, err) in enumerate(position_series(s).values()):
        top, bottom = lines(axes[col]), lines(axes[3 + col])
        np.testing.assert_array_equal(top["flown"].get_xdata(), s.time_s)
        np.testing.assert_array_equal(top["flown"].get_ydata(), truth)
        np.testing.assert_array_equal(top["reference"].get_ydata(), ref)
        np.testing.assert_array_equal(bottom["error"].get_ydata(), err)
    # the altitude panel is -z_NED, its error the table's z error with the sign of altitude
    _, alt, e_alt = position_series(s)["Z"]
    np.testing.assert_array_equal(alt, -s.pos_ned[:, 2])
    np.testing.assert_allclose(-e_alt[s.flying], s.position_error()[:, 2], rtol=0, atol=1e-15)
    # fault onset marked on every tracking panel
    marks = [np.asarray(line.get_xdata())[0] for line in axes[0].get_lines()
             if line.get_label() == "_fault"]
    assert marks == [flight["analyzer"].injections[0].time_s]
    rpy = figs["rpy"].axes
    for col, (ref, truth, err) in enumerate(attitude_series(s).values()):
        np.testing.assert_array_equal(lines(rpy[col])["flown"].get_ydata(), truth)
        np.testing.assert_array_equal(lines(rpy[col])["reference"].get_ydata(), ref)
        np.testing.assert_array_equal(lines(rpy[3 + col])["error"].get_ydata(), err)
        e_att = np.asarray(lines(rpy[3 + col])["error"].get_ydata())
        np.testing.assert_array_equal(e_att[s.flying], s.attitude_error_deg()[:, col])
    pwm_axes = figs["pwm"].axes
    assert [ax.get_ylabel() for ax in pwm_axes] == [f"u{m} (PWM)" for m in (1, 2, 3, 4)]
    for j, ax in enumerate(pwm_axes):
        line = lines(ax)[f"motor {j + 1}"]
        np.testing.assert_array_equal(line.get_xdata(), s.pwm_time_s)
        np.testing.assert_array_equal(line.get_ydata(), s.pwm[:, j])
    for j, ax in enumerate(figs["loe"].axes):
        assert ax.get_title() == f"motor {j + 1}"
        np.testing.assert_array_equal(lines(ax)["estimated"].get_ydata(), s.loe_estimate[j])
        np.testing.assert_array_equal(lines(ax)["injected"].get_ydata(), s.loe_injected[:, j])
    ax3, above = figs["trajectory"].axes
    assert ax3.name == "3d" and ax3.get_zlabel() == "altitude Z = -z (m)"  # type: ignore[attr-defined]
    flown = lines(above)["flown"]
    np.testing.assert_array_equal(flown.get_xdata(), s.pos_ned[:, 1])  # east across
    np.testing.assert_array_equal(flown.get_ydata(), s.pos_ned[:, 0])  # north up


def test_report_command_rebuilds_the_views_from_the_tlog(
        flight: dict[str, Any], tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    rrd, figs, rep = tmp_path / "again.rrd", tmp_path / "figs", tmp_path / "rep"
    assert main(["report", str(flight["tlog"]), "--rrd", str(rrd), "--figures", str(figs),
                 "--report", str(rep)]) == 0
    out, err = capsys.readouterr()
    assert f"recording: {rrd}" in out and f"report: {rep / 'report.md'}" in out
    # each slow step said what it was doing (stderr is not a terminal: plain lines)
    assert err.splitlines() == [
        f"ftc-gcs: reading {flight['tlog']}...",
        f"ftc-gcs: writing the recording {rrd}...",
        f"ftc-gcs: writing figures (5 kinds, PNG and PDF) in {figs}...",
        f"ftc-gcs: writing the report in {rep} (copying its figures: 5 kinds, PNG and PDF)..."]
    _, again = scalar_series(rrd, "/plots/error/z")
    _, first = scalar_series(flight["rrd"], "/plots/error/z")
    np.testing.assert_array_equal(again, first)
    assert len(list(figs.glob("*.png"))) == 5 and len(list(figs.glob("*.pdf"))) == 5
    assert (rep / "report.md").read_text().count("](figures/") >= 5
