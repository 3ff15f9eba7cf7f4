"""``ftc-vehicle`` options: ``--instance N`` ports, ``--signing-key`` KEY and ``--speedup max``
(unthrottled, telemetry at simulated-time rates), bad values in one line (exit status 2)."""

from __future__ import annotations

import hashlib
import math
import socket

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mav

from fcu.mavlink.telemetry.streams import DEFAULT_RATES_HZ
from sim.instances import MAX_INSTANCE, instance_addresses
from sim.scenario import load_scenario
from sim.vehicle import VehicleOptions, VehicleProcess
from sim.vehicle_cli import build_parser, main

LOOPBACK = "127.0.0.1"


def test_instance_zero_is_the_usual_ports() -> None:
    assert instance_addresses(0) == ((LOOPBACK, 14555), ((LOOPBACK, 14550), (LOOPBACK, 14540)))


def test_instance_n_moves_the_ports_by_ten_n_as_ardupilot_sitl() -> None:
    assert instance_addresses(1) == ((LOOPBACK, 14565), ((LOOPBACK, 14560), (LOOPBACK, 14541)))
    assert instance_addresses(9) == ((LOOPBACK, 14645), ((LOOPBACK, 14640), (LOOPBACK, 14549)))


def test_no_port_of_one_instance_is_a_port_of_another() -> None:
    owners: dict[int, int] = {}
    for n in range(MAX_INSTANCE + 1):
        bind, outs = instance_addresses(n)
        for _, port in (bind, *outs):
            assert owners.setdefault(port, n) == n, f"port {port}: instances {owners[port]}, {n}"
    assert len(owners) == 3 * (MAX_INSTANCE + 1)


def test_the_options_parse() -> None:
    args = build_parser().parse_args(["--instance", "3", "--signing-key", "secret"])
    assert args.instance == 3
    assert args.signing_key == hashlib.sha256(b"secret").digest()
    assert args.bind is None and args.out is None  # resolved from the instance in main()
    assert build_parser().parse_args(["--speedup", "max"]).speedup == math.inf


def test_unthrottled_vehicle_streams_at_simulated_time_rates() -> None:
    sim_s = 3.0  # s simulated
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as client:
        client.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4 << 20)
        client.bind((LOOPBACK, 0))
        process = VehicleProcess(VehicleOptions(
            scenario=load_scenario("baseline"), speedup=math.inf, bind=(LOOPBACK, 0),
            outs=(client.getsockname(),), max_sim_s=sim_s))
        process.open()
        try:
            summary = process.run(lambda: False)
        finally:
            process.close()
        client.setblocking(False)
        parser = mav.MAVLink(None)
        times_ms: list[int] = []
        while True:
            try:
                data = client.recv(65535)
            except BlockingIOError:
                break
            times_ms += [m.time_boot_ms for m in parser.parse_buffer(data) or []
                         if m.get_type() == "ATTITUDE"]
    assert summary.sim_s == pytest.approx(sim_s) and summary.reanchors == 0
    assert process.vehicle.sim_params.speedup == 0.0  # SIM_SPEEDUP 0: unthrottled
    # ATTITUDE at its rate in simulated time, one per 50 ms tick boundary, from t = 0
    rate_hz = DEFAULT_RATES_HZ[mav.MAVLINK_MSG_ID_ATTITUDE]
    assert len(times_ms) == round(sim_s * rate_hz) + 1
    assert sorted(set(times_ms)) == times_ms  # in simulated-time order, none repeated


@pytest.mark.parametrize(("argv", "words"), [
    (["--instance", "10"], "argument --instance: 10: must be in 0..9"),
    (["--speedup", "0"], "argument --speedup: '0': must be a finite number > 0"),
    (["--speedup", "inf"], "argument --speedup: 'inf': must be a finite number > 0"),
    (["--instance", "-1"], "argument --instance: -1: must be in 0..9"),
    (["--instance", "one"], "argument --instance: 'one' is not an integer"),
    (["--signing-key", "hex:1234"], "argument --signing-key: signing key: after 'hex:' give "
     "exactly 64 hexadecimal digits"),
    (["--signing-key", "two words"], "argument --signing-key: signing key: a passphrase is "
     "printable ASCII without spaces"),
    (["--signing-key", "hex:" + "00" * 32], "the all-zero key means no signing"),
])
def test_bad_values_are_one_line_errors(argv: list[str], words: str,
                                        capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exit_info:
        main(argv)
    assert exit_info.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("ftc-vehicle: error: ")
    assert words in err
    assert "Traceback" not in err
