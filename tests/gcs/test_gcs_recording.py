"""Aligned series, rerun recordings, figures and reports of synthetic MAVLink streams.

No vehicle, no viewer: a synthetic stream (``test_gcs_analysis.Stream``) with known errors,
its :meth:`FlightAnalyzer.series` recorded (:mod:`flightdata.recording`) and read back with
``rerun.recording.load_recording(...).schema()``, drawn (:mod:`flightdata.figures`) and
checked through matplotlib objects (headless, no pyplot). The same checks on a real flight
are in tests/integration/test_gcs_views.py; the toolkit's own on headless flights in
tests/flightdata/.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
import rerun as rr
from test_gcs_analysis import Stream, north_of, vn_of

from fcu.mavlink.telemetry.record_relay import record_message
from flightdata.figures import figure_kinds, make_figures, position_series, save_figures
from flightdata.recording import (
    SIM_TIMELINE,
    LiveRecorder,
    RecordingConfig,
    open_stream,
    write_recording,
)
from flightdata.records import FaultRecord
from flightdata.series import FlightSeries
from gcs.cli import build_parser
from gcs.report import write_report

FAULT_AT_S = 1.0  # s, motor 3 loses 20 % in the synthetic flight
FIGURE_KINDS = figure_kinds()


def synthetic_flight(stream: Stream | None = None, *,
                     on_tick: Callable[[float | None], None] | None = None) -> Stream:
    """2 s at 100 Hz: ground tick, then flying with a +-4 mm north error; a fault at 1 s."""
    s = stream if stream is not None else Stream()
    s.boot()
    s.tick(0.0, north_m=0.0, ref_north_m=0.0, roll=0.0, ref_roll=0.0, alt_m=0.0,
           servo_us=1100, vn_m_s=vn_of(0.0))
    for k in range(1, 201):
        t = k * 0.01
        if k == round(FAULT_AT_S * 100):
            s.v(record_message(FaultRecord(time_s=t, action="started", kind="loe", motor=3,
                                           magnitude=0.2, fault_id=1, profile="step"), 1, t))
        err = 0.004 if k % 2 else -0.002
        s.tick(t, north_m=north_of(t), ref_north_m=north_of(t) + err, roll=0.01, ref_roll=0.03,
               vn_m_s=vn_of(t), servo_us=1400 + k)
        if on_tick is not None:
            on_tick(s.analyzer.clock_s)
    return s


@pytest.fixture(scope="module")
def series() -> FlightSeries:
    return synthetic_flight().analyzer.series()


def test_series_is_what_the_table_is_computed_from() -> None:
    s = synthetic_flight()
    fs, rep = s.analyzer.series(), s.analyzer.report()
    assert len(fs.time_s) == 201 and np.count_nonzero(fs.flying) == rep.samples == 200
    assert not fs.flying[0]  # on the ground
    err = fs.position_error()
    assert math.sqrt(np.mean(err[:, 0] ** 2)) == pytest.approx(rep.rms["x"], rel=1e-12)
    att = fs.attitude_error_deg()
    assert math.sqrt(np.mean(att[:, 0] ** 2)) == pytest.approx(rep.rms["roll"], rel=1e-12)
    assert np.max(np.abs(att[:, 0])) == pytest.approx(math.degrees(0.02), rel=1e-5)
    # 1400 + k us: PWM = 0.05 (servo - 1000) / 1000 at each servo time
    np.testing.assert_allclose(fs.pwm[:, 0], 0.05 * (400 + np.r_[-300, np.arange(1, 201)]) / 1e3)
    np.testing.assert_allclose(fs.pwm_time_s, fs.time_s, atol=1e-9)
    # the fault is dated by the tick after its STATUSTEXT and held from then on
    before = fs.time_s < FAULT_AT_S - 1e-9
    assert np.all(fs.loe_injected[before] == 0.0)
    assert np.all(fs.loe_injected[~before] == [0.0, 0.0, 0.2, 0.0])
    assert fs.fault_times_s == (pytest.approx(FAULT_AT_S),)
    # telemetry has no estimate, no wind, no take-off/landing phase
    assert fs.est_pos_ned is None and fs.wind_ned is None and fs.free_flight is None
    assert [e.kind for e in fs.events if e.kind == "INJECT"] == ["INJECT"]


EXPECTED = {("/world", "ViewCoordinates:xyz"), ("/world/vehicle", "Transform3D:translation"),
            ("/world/vehicle/rotors", "Cylinders3D:colors"), ("/events", "TextLog:text"),
            ("/plots/error/x", "Scalars:scalars"), ("/plots/loe/3/true", "Scalars:scalars"),
            ("/plots/pwm/4", "Scalars:scalars"), ("/world/flown_path", "LineStrips3D:strips")}


def _schema(path: Path) -> tuple[set[tuple[str, str]], set[str]]:
    schema = rr.recording.load_recording(path).schema()
    return ({(c.entity_path, c.component) for c in schema.component_columns()},
            {c.name for c in schema.index_columns()})


def test_a_written_recording_has_the_entities_on_sim_time(series: FlightSeries,
                                                          tmp_path: Path) -> None:
    path = tmp_path / "s.rrd"
    stream = open_stream("synthetic", rrd_path=path, recording_id="synthetic")
    write_recording(series, stream)
    stream.disconnect()
    columns, timelines = _schema(path)
    assert EXPECTED <= columns and SIM_TIMELINE in timelines
    # no wind and no estimate in the telemetry: not invented
    assert not any(e.startswith(("/world/wind", "/plots/position/x/estimate"))
                   for e, _ in columns)
    assert rr.recording.load_recording(path).recording_id() == "synthetic"


def test_live_recorder_sends_as_the_clock_advances(tmp_path: Path) -> None:
    path = tmp_path / "live.rrd"
    s = Stream()
    live = LiveRecorder(open_stream("live", rrd_path=path), s.analyzer.series,
                        RecordingConfig(flush_s=0.5), owns_stream=True, min_wall_s=0.0)
    sent: list[int] = []

    def on_clock(clock_s: float | None) -> None:
        assert clock_s is not None
        live.on_clock(clock_s)
        sent.append(live.recorder.rows_sent)

    synthetic_flight(s, on_tick=on_clock)
    # first clock seen 0.01 s: sends at 0.51, 1.01, 1.51 s, of the rows up to 0.1 s
    # (holdback) before the clock: t = 0 to 0.41, 0.91, 1.41 s
    assert live.flushes == 3
    assert sorted(set(sent)) == [0, 42, 92, 142]
    live.close()
    assert live.recorder.rows_sent == 201
    columns, timelines = _schema(path)
    assert EXPECTED <= columns and SIM_TIMELINE in timelines


@pytest.mark.slow  # a whole flight or figure set: make test only
def test_figures_are_built_headless_from_the_series(series: FlightSeries,
                                                    tmp_path: Path) -> None:
    figs = make_figures(series, name="synthetic")
    assert list(figs) == list(FIGURE_KINDS)
    assert figs["xyz"].get_suptitle().startswith("synthetic: position")
    top_x = figs["xyz"].axes[0]
    flown = next(line for line in top_x.get_lines() if line.get_label() == "flown")
    np.testing.assert_array_equal(flown.get_ydata(), position_series(series)["X"][1])
    err = next(line for line in figs["xyz"].axes[3].get_lines() if line.get_label() == "error")
    e_x = np.asarray(err.get_ydata())
    np.testing.assert_array_equal(e_x[series.flying], series.position_error()[:, 0])
    assert np.isnan(e_x[0])  # on the ground: a gap
    faults = [np.asarray(line.get_xdata())[0] for line in top_x.get_lines()
              if line.get_label() == "_fault"]
    assert faults == [pytest.approx(FAULT_AT_S)]
    loe3 = figs["loe"].axes[2]
    assert loe3.get_title() == "motor 3"
    assert {line.get_label() for line in loe3.get_lines()} >= {"injected", "estimated"}
    written = save_figures(series, tmp_path / "figs")
    assert [p.suffix for p in written["pwm"]] == [".png", ".pdf"]
    assert all(p.stat().st_size > 0 for paths in written.values() for p in paths)


@pytest.mark.slow  # a whole flight or figure set: make test only
def test_report_embeds_the_figures_next_to_the_table(tmp_path: Path) -> None:
    s = synthetic_flight()
    md = write_report(tmp_path / "rep", s.analyzer.report(), s.analyzer.series(), title="T")
    text = md.read_text()
    assert text.startswith("# T\n") and "control effort" in text
    for kind in FIGURE_KINDS:
        assert f"(figures/{kind}.png)" in text and f"[{kind}](figures/{kind}.pdf)" in text
        assert (md.parent / "figures" / f"{kind}.png").is_file()


def test_view_options_parse() -> None:
    p = build_parser()
    args = p.parse_args(["fly", "--rerun", "--rrd", "a.rrd", "--figures", "f", "--report", "r"])
    assert (args.rerun, args.rrd, args.figures, args.report) == ("spawn", Path("a.rrd"),
                                                                 Path("f"), Path("r"))
    args = p.parse_args(["demo", "--rerun", "rerun+http://127.0.0.1:9876/proxy"])
    assert args.rerun == "rerun+http://127.0.0.1:9876/proxy"
    assert p.parse_args(["fly"]).rerun is None
    args = p.parse_args(["report", "f.tlog", "--rrd", "x.rrd", "--report", "d"])
    assert (args.rrd, args.figures, args.report) == (Path("x.rrd"), None, Path("d"))
