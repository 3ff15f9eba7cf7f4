"""group_samples: the per-kind mean of a tick's samples, whether they come one object each or
as arrays (fcu.hal.SensorSampleArrays, how the simulator hands them out)."""

from __future__ import annotations

import math

import numpy as np

from fcu.estimation.state import group_samples
from fcu.hal import SensorSample
from flightdata.vocabulary import SENSOR_AXES, SENSORS


class ArraySamples:
    """The samples of a list as arrays, the layout of fcu.hal.SensorSampleArrays."""

    sensor_names = SENSORS
    sensor_axes = tuple(SENSOR_AXES[name] for name in SENSORS)

    def __init__(self, samples: list[SensorSample]) -> None:
        self.sensor_index = np.array([SENSORS.index(s.sensor) for s in samples], dtype=np.int64)
        self.time_s = np.array([s.time_s for s in samples], dtype=float)
        self.values = np.zeros((len(samples), 3))
        for j, s in enumerate(samples):
            self.values[j, :len(s.value)] = s.value


def random_tick(rng: np.random.Generator) -> list[SensorSample]:
    """Up to 14 samples of any kinds, yaws near +-pi, one in ten with a non-finite entry."""
    samples = []
    for j in range(int(rng.integers(0, 15))):
        name = SENSORS[int(rng.integers(0, len(SENSORS)))]
        value = rng.normal(size=SENSOR_AXES[name])
        if name == "mocap_att":
            value[2] = math.pi - 0.01 + 0.02 * rng.normal()  # either side of +-pi
        if rng.random() < 0.1:
            value[int(rng.integers(0, value.size))] = (np.nan, np.inf, -np.inf)[j % 3]
        samples.append(SensorSample(name, 1.0 + 0.002 * j, value))
    return samples


def test_arrays_and_objects_group_alike_to_the_bit() -> None:
    rng = np.random.default_rng(7)
    for _ in range(500):
        samples = random_tick(rng)
        for kinds in (SENSORS, frozenset({"gyro", "mocap_att"}), ["baro"]):
            from_objects = group_samples(samples, kinds)
            from_arrays = group_samples(ArraySamples(samples), kinds)  # type: ignore[arg-type]
            assert list(from_arrays) == list(from_objects)  # same kinds, same order
            for name, batch in from_objects.items():
                other = from_arrays[name]
                np.testing.assert_array_equal(other.value, batch.value)
                assert (other.time_s, other.count) == (batch.time_s, batch.count)


def test_means_drop_non_finite_samples_and_average_yaw_across_pi() -> None:
    samples = [
        SensorSample("gyro", 0.002, np.array([1.0, 2.0, 3.0])),
        SensorSample("gyro", 0.004, np.array([3.0, np.nan, 5.0])),  # dropped
        SensorSample("gyro", 0.006, np.array([2.0, 4.0, 6.0])),
        SensorSample("mocap_att", 0.004, np.array([0.0, 0.0, math.pi - 0.1])),
        SensorSample("mocap_att", 0.008, np.array([0.2, 0.0, -math.pi + 0.3])),
        SensorSample("battery", 0.006, np.array([12.0, 3.0])),  # not a kind asked for
    ]
    for given in (samples, ArraySamples(samples[:5])):
        batches = group_samples(given, SENSORS)  # type: ignore[arg-type]
        assert list(batches) == ["gyro", "mocap_att"]
        np.testing.assert_array_equal(batches["gyro"].value, [1.5, 3.0, 4.5])
        assert batches["gyro"].count == 2
        assert batches["gyro"].time_s == 0.004  # mean of 0.002 and 0.006
        # pi - 0.1 and -pi + 0.3 are 0.2 apart across +-pi: their mean is pi + 0.1, wrapped
        att = batches["mocap_att"].value
        assert abs(att[2] - (-math.pi + 0.1)) < 1e-12  # two roundings of values near pi
        assert att[0] == 0.1


def test_measurement_tables_read_from_the_grouped_table_equal_those_read_batch_by_batch(
) -> None:
    from fcu.estimation.ekf import ExtendedKalmanEstimator
    from fcu.estimation.tskf import TwoStageKalmanFilter
    from fcu.model import VehicleModel

    model = VehicleModel()
    channel_sets = [est._make_channels(source)  # noqa: SLF001 (the filters' channel sets)
                    for est in (ExtendedKalmanEstimator(model), TwoStageKalmanFilter(model))
                    for source in ("mocap", "baro")]
    rng = np.random.default_rng(11)
    for _ in range(300):
        samples = random_tick(rng)
        for grouped in (group_samples(samples), group_samples(ArraySamples(samples))):
            for channels in channel_sets:
                fast = channels.measurements(grouped)
                slow = channels.measurements(dict(grouped))  # a plain mapping: batch by batch
                assert fast.dtype == slow.dtype and fast.shape == slow.shape
                np.testing.assert_array_equal(fast, slow)


def test_a_grouping_read_lazily_holds_what_an_eager_one_holds_and_pop_removes_a_kind() -> None:
    rng = np.random.default_rng(5)
    for _ in range(200):
        samples = random_tick(rng)
        for source in (samples, ArraySamples(samples)):
            eager = group_samples(source)  # type: ignore[arg-type]
            eager_items = {name: (b.value.tolist(), b.time_s, b.count)
                           for name, b in eager.items()}  # built as a whole first
            lazy = group_samples(source)  # type: ignore[arg-type]
            present = list(eager_items)
            gone = present[0] if present else "gyro"
            popped = lazy.pop(gone)  # before the batches are built
            assert (popped is None) == (not present)
            if popped is not None:
                assert (popped.value.tolist(), popped.time_s, popped.count) == \
                    eager_items[gone]
            assert lazy.pop(gone) is None  # once only
            assert lazy.popped == ((gone,) if present else ())
            rest = {k: v for k, v in eager_items.items() if k != gone}
            assert list(lazy) == list(rest)  # order of first samples kept
            assert {name: (b.value.tolist(), b.time_s, b.count)
                    for name, b in lazy.items()} == rest
            assert gone not in lazy and lazy.get(gone) is None
            # the spare zero after the table, which absent channels read
            assert lazy.flat[-1] == 0.0 and lazy.flat.size == lazy.table.size + 1


def test_pop_value_removes_a_kind_as_pop_does_and_gives_its_mean() -> None:
    rng = np.random.default_rng(8)
    for _ in range(200):
        samples = random_tick(rng)
        for source in (samples, ArraySamples(samples)):
            sensor = SENSORS[int(rng.integers(0, len(SENSORS)))]
            by_pop, by_value = group_samples(source), group_samples(source)  # type: ignore[arg-type]
            if rng.random() < 0.5:  # either before the batches are built or after
                dict(by_pop), dict(by_value)
            batch = by_pop.pop(sensor)
            value = by_value.pop_value(sensor)
            assert value == (None if batch is None else batch.value.tolist())
            assert by_value.popped == by_pop.popped
            assert by_value.pop_value(sensor) is None  # once only
            assert dict(by_value).keys() == dict(by_pop).keys()
