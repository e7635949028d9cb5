"""The reference recordings in bags/: no live graph, no rclpy.

Every message decodes with an independent reader (`mcap` + `mcap-ros2-support`);
each bag's telemetry is exactly the window the monitor fitted; the current monitor
gives the recorded k the recorded fitness (a stale bag fails), and replaying the
isolation with the recorded settings gives the recorded k within the spread measured
across machines (never bit for bit: the bags were recorded on another machine).
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest
import yaml

from ema_phm.diagnosis import health
from ema_phm.diagnosis.fitness import DEFAULT_FITNESS, Fitness
from ema_phm.diagnosis.isolation import DEFAULT_PRESET, isolate
from ema_phm.domain.faults import LABELS, N_K
from ema_phm.domain.window import CHANNELS
from ema_phm.model.belief import MonitorBelief
from ema_phm.model.monitor_model import MonitorModel
from ema_phm.monitor import status_texts
from ema_phm.telemetry import bags
from ema_phm.telemetry.window_assembler import read_fitted_windows
from ema_phm.telemetry.wire import (
    DIAGNOSTICS_TOPIC,
    HEALTH_TOPIC,
    WINDOW_TOPIC,
    decode_health,
    decode_telemetry,
)

ROOT = Path(__file__).resolve().parents[2]
BAGS = ROOT / "bags"
NAMES = (
    "nominal",
    "friction",
    "backlash",
    "short_circuit",
    "eccentricity",
    "gain_drift",
    "multi_fault",
    "realistic_unit",
)
#: Bags of the second packaged actuator (a PI current loop in dq): both nodes were given its
#: actuator file, so the monitor that replays them is that file's.
SMALL_PI_NAMES = ("small_pi_nominal", "small_pi_friction", "small_pi_gain_drift")
SMALL_PI = ROOT / "config" / "actuators" / "small_pi_ema.yaml"
#: Replayed (a full isolation each, ~8 s) on every run; EMA_PHM_FULL_REPLAY=1 replays all bags.
ALWAYS_REPLAYED = ("nominal", "multi_fault")


def _bag(name: str) -> Path:
    path = BAGS / name
    if not (path / "metadata.yaml").is_file():
        pytest.fail(
            f"reference bag {path} is missing; make it with python -m bench.make_reference_bags"
        )
    return path


def recorded(path: Path) -> dict:
    """The bag's last /ema/health vector and the /diagnostics status that reported it."""
    healths, statuses = [], []
    for topic, _type, _t, msg in bags.read_messages(path, [HEALTH_TOPIC, DIAGNOSTICS_TOPIC]):
        if topic == HEALTH_TOPIC:
            # bags recorded before the prognosis hold the fit-only layout
            labels = [d.label for d in msg.layout.dim]
            assert labels in ([health.HEALTH_LABEL], [",".join(health.HEALTH_FIELDS_FIT)])
            healths.append(decode_health(msg))
            assert list(healths[-1]) == list(health.HEALTH_FIELDS)
        else:
            statuses += [s for s in msg.status if s.name.endswith(": actuator")]
    assert healths, f"{path} has no {HEALTH_TOPIC}"
    h = healths[-1]
    k = [h[label] for label in LABELS]
    final = [
        s for s in statuses if not s.message.startswith(("isolating", "waiting", "commissioning"))
    ]
    assert final, f"{path} has no result status on {DIAGNOSTICS_TOPIC}"
    values = status_texts.parse_values([(v.key, v.value) for v in final[-1].values])
    interval = np.array([[values[f"{k}_low"], values[f"{k}_high"]] for k in LABELS])
    adequacy = {key: values[f"adequacy_{key}"] for key in ("statistic", "threshold", "ok")}
    adequacy["ok"] = adequacy["ok"] in (True, "true")
    return {
        "k": np.array(k),
        "health": h,
        "values": values,
        "status": final[-1],
        "k_interval": interval,
        "adequacy": adequacy,
        # by name: the window's load channel decided which were searched (nuisance.searched)
        "nuisance": {
            key.removeprefix("nuisance_"): float(v)
            for key, v in values.items()
            if key.startswith("nuisance_")
        },
    }


def assess_recorded(rec: dict, k_true=None) -> health.Assessment:
    """The recorded fit judged now, with its recorded intervals and adequacy."""
    return health.assess(
        rec["k"], k_true=k_true, k_interval=rec["k_interval"], adequacy=rec["adequacy"]
    )


def test_bags_readme_lists_every_bag_and_sizes_are_small():
    text = (BAGS / "README.md").read_text(encoding="utf-8")
    for name in NAMES + SMALL_PI_NAMES:
        path = _bag(name)
        assert f"`{name}`" in text
        size = sum(f.stat().st_size for f in path.iterdir())
        assert size <= 2_000_000, f"{name} is {size} bytes"
    assert sorted(p.name for p in BAGS.iterdir() if p.is_dir()) == sorted(NAMES + SMALL_PI_NAMES)


@pytest.mark.parametrize("name", NAMES)
def test_every_message_decodes_with_an_independent_reader(name):
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    path = _bag(name)
    meta = yaml.safe_load((path / "metadata.yaml").read_text(encoding="utf-8"))[
        "rosbag2_bagfile_information"
    ]
    assert meta["storage_identifier"] == "mcap"
    expected = {
        t["topic_metadata"]["name"]: t["message_count"] for t in meta["topics_with_message_count"]
    }
    (mcap_file,) = path.glob("*.mcap")
    counts: dict[str, int] = {}
    with open(mcap_file, "rb") as fh:
        reader = make_reader(fh, decoder_factories=[DecoderFactory()])
        for _schema, channel, _message, msg in reader.iter_decoded_messages():
            counts[channel.topic] = counts.get(channel.topic, 0) + 1
            if channel.topic in (bags.TELEMETRY_TOPIC, WINDOW_TOPIC):
                first, second = (d.label for d in msg.layout.dim)
                # "samples", on the telemetry followed by the stream's identity (issue 17)
                name, _, identity = first.partition(" ")
                assert name == "samples" and second == "channels"
                if channel.topic == bags.TELEMETRY_TOPIC:
                    assert json.loads(identity)["hardware_id"] == "ema_sim"
                assert msg.layout.dim[1].size == len(CHANNELS)
                assert len(msg.data) == msg.layout.dim[0].size * len(CHANNELS)
            elif channel.topic == bags.RUN_INFO_TOPIC:
                info = json.loads(msg.data)
                assert {
                    "sample_rate",
                    "window_duration",
                    "samples_per_window",
                    "command",
                    "load",
                } <= set(info)
            elif channel.topic == bags.GROUND_TRUTH_TOPIC:
                assert [d.label for d in msg.layout.dim] == ["k"] and len(msg.data) == N_K
            elif channel.topic == HEALTH_TOPIC:
                assert len(msg.data) in (len(health.HEALTH_FIELDS), len(health.HEALTH_FIELDS_FIT))
            elif channel.topic == DIAGNOSTICS_TOPIC:
                # diagnostic_updater's naming: the node's name without its leading slash
                assert msg.status[0].name == "monitor_node: actuator"
    assert counts == expected
    for topic in (bags.RUN_INFO_TOPIC, bags.GROUND_TRUTH_TOPIC, WINDOW_TOPIC, HEALTH_TOPIC):
        assert counts[topic] == 1, (topic, counts)
    assert counts[bags.TELEMETRY_TOPIC] >= 1 and counts[DIAGNOSTICS_TOPIC] >= 1


@pytest.mark.parametrize("name", NAMES)
def test_telemetry_is_exactly_the_fitted_window(name):
    path = _bag(name)
    (fitted,) = read_fitted_windows(path)
    tel = np.concatenate(
        [
            decode_telemetry(m)
            for topic, _t, _ts, m in bags.read_messages(path, [bags.TELEMETRY_TOPIC])
        ]
    )
    np.testing.assert_array_equal(tel, fitted.matrix())
    w = bags.read_window(path)  # what `ema-phm isolate` reads
    np.testing.assert_array_equal(w.matrix(), fitted.matrix())
    info = w.meta
    n = int(info["samples_per_window"])
    assert w.n == n + 1 and w.t[0] == 0.0 and w.t[-1] == pytest.approx(info["window_duration"])
    rec = recorded(path)
    assert rec["health"]["window_t0"] == w.t[0] and rec["health"]["window_t1"] == w.t[-1]
    np.testing.assert_array_equal(w.k_true, info["k_true"])
    # recorded with the library's default preset and the full budget (what the CLI runs by default)
    assert rec["values"]["preset"] == DEFAULT_PRESET, (
        "isolation.DEFAULT_PRESET changed: remake the bags with "
        "python -m bench.make_reference_bags --force"
    )
    assert rec["values"]["max_evaluations"] == 0
    assert rec["values"]["fitness_weighting"] == DEFAULT_FITNESS  # "default" is recorded resolved
    assert rec["health"]["percent_err"] == pytest.approx(rec["values"]["percent_err"], rel=1e-5)


#: Single-fault bags whose recorded diagnosis names another fault (strict: when a better
#: monitor names the right fault, remake the bags and drop the entry).  Issue 9's backlash
#: entry went with issue 10: the monitor names the HF's backlash now.
MISNAMED: dict[str, str] = {}


@pytest.mark.parametrize("name", NAMES)
def test_recorded_level_follows_thresholds(name):
    """The recorded level is what the thresholds say of the recorded k; faults are flagged.

    No %err bound: against the truthful HF (issue 9) the bags' %err is 5.6-62 % (listed in
    bags/README.md); accuracy is bench/bench_realistic.py's to measure, not this test's.
    """
    rec = recorded(_bag(name))
    w = bags.read_window(_bag(name))
    a = assess_recorded(rec, k_true=w.k_true)
    assert int(rec["status"].level) == a.level and rec["health"]["level"] == a.level
    assert a.percent_err == pytest.approx(rec["health"]["percent_err"], rel=1e-6)
    if health.severity(w.k_true).max() > 0:
        assert a.level > health.OK
    else:
        assert a.level == health.OK


@pytest.mark.parametrize(
    "name",
    [
        pytest.param(n, marks=pytest.mark.xfail(strict=True, reason=MISNAMED[n]))
        if n in MISNAMED
        else n
        for n in NAMES
    ],
)
def test_single_fault_is_the_one_named(name):
    w = bags.read_window(_bag(name))
    sev_true = health.severity(w.k_true)
    if (sev_true > 0).sum() != 1:
        pytest.skip("not a single-fault bag")
    a = assess_recorded(recorded(_bag(name)))
    assert a.as_dict()["dominant_fault"] == health.assess(w.k_true).as_dict()["dominant_fault"]


#: Tolerances of the replay checks, chosen by measurement: the bags were recorded on one
#: machine and are replayed on another (and under NUMBA_CPU_NAME=generic).
#: - F(recorded k, recorded nuisances) on the bag's window: the nuisances come from the
#:   /diagnostics text (6 significant digits), so F moved by up to 2.0e-4 (relative, the
#:   eccentricity bag; 1e-9..6e-8 for the others) on the recording machine; a stale bag moves
#:   it far more (the monitor's motor inertia +1 % moves the multi-fault bag's F by 12 %).
FITNESS_OF_RECORDED_K_RTOL = 2e-3
#: - a whole re-isolation follows the optimizer's path, which rounding differences bend where
#:   the fitness is flat or multimodal.  Between machines of one kind that differ in SIMD
#:   (numpy's runtime dispatch: AVX-512 or only AVX2, whatever NUMBA_CPU_NAME says) it lands
#:   elsewhere: the nominal bag's best fitness 2.0e-3 worse (k7, not identifiable there, 0.81
#:   vs 0.80), the multi-fault bag's 24 % better (another optimum).  So a replay is held to
#:   what holds on any machine: a fit no worse than the live monitor's (within this slack),
#:   the same fault named, a like budget; not to the recorded k.
REPLAY_FITNESS_SLACK = 1e-2


def fitness_of_recorded_k(
    path: Path, *, belief: MonitorBelief | None = None
) -> tuple[float, float]:
    """(fitness of the recorded k on the bag's window now, fitness the monitor recorded)."""
    rec = recorded(path)
    window = bags.read_window(path)
    model = None if belief is None else MonitorModel(window, belief=belief)
    fitness = Fitness(
        window, weights=rec["values"]["fitness_weighting"], model=model, nuisance=True
    )
    row = np.concatenate(
        [
            rec["k"],
            [n.normalized(rec["nuisance"][n.name]) for n in fitness.nuisances],
        ]
    )
    return float(fitness(row[None])[0]), float(rec["health"]["fitness"])


@pytest.mark.parametrize("name", NAMES)
def test_recorded_k_still_scores_the_recorded_fitness(name):
    """A stale bag (a monitor-model change since it was recorded) fails here, on any machine."""
    now, then = fitness_of_recorded_k(_bag(name))
    assert now == pytest.approx(then, rel=FITNESS_OF_RECORDED_K_RTOL, abs=0), (
        "the monitor model changed since this bag was recorded: remake bags/ with "
        "python -m bench.make_reference_bags"
    )


def test_a_monitor_change_is_caught_by_the_fitness_check():
    """The check above is sensitive: 1 % more motor inertia moves F(recorded k) by 12 %."""
    default = MonitorBelief.default()
    belief = default.with_values({"mechanics.j_motor": 1.01 * default.value("mechanics.j_motor")})
    now, then = fitness_of_recorded_k(_bag("multi_fault"), belief=belief)
    assert abs(now - then) / then > 30 * FITNESS_OF_RECORDED_K_RTOL


@pytest.mark.parametrize(
    "name",
    [
        n
        if n in ALWAYS_REPLAYED
        else pytest.param(
            n,
            marks=pytest.mark.skipif(
                os.environ.get("EMA_PHM_FULL_REPLAY") != "1",
                reason="set EMA_PHM_FULL_REPLAY=1 to replay every bag",
            ),
        )
        for n in NAMES
    ],
)
def test_replay_gives_the_recorded_k(name):
    """Read bag -> isolate with the recorded settings -> the k the live monitor published.

    Within the measured cross-machine spread, not bit for bit.
    """
    path = _bag(name)
    rec = recorded(path)
    v = rec["values"]
    res = isolate(
        bags.read_window(path),
        preset=v["preset"],
        seed=int(v["seed"]),
        weights=v["fitness_weighting"],
        max_evaluations=int(v["max_evaluations"]) or None,
        nuisance=True,
        intervals=True,
    )
    assert res.fitness <= rec["health"]["fitness"] * (1 + REPLAY_FITNESS_SLACK), (res.k, rec["k"])
    named = health.assess(res.k).as_dict()["dominant_fault"]
    assert named == health.assess(rec["k"]).as_dict()["dominant_fault"], (res.k, rec["k"])
    assert (
        abs(res.evaluations - rec["health"]["evaluations"]) <= 0.05 * rec["health"]["evaluations"]
    )


def _small_pi_belief() -> MonitorBelief:
    from ema_phm.physics.actuator_file import load_actuator

    return MonitorBelief.for_actuator(load_actuator(SMALL_PI))


def _small_pi_fitness_of_recorded_k(path: Path, belief: MonitorBelief) -> float:
    """F(recorded k, recorded nuisances) on the bag's window by the monitor of `belief`."""
    rec = recorded(path)
    fitness = Fitness(
        bags.read_window(path),
        weights=rec["values"]["fitness_weighting"],
        belief=belief,
        nuisance=True,
    )
    nu = [n.normalized(rec["nuisance"][n.name]) for n in fitness.nuisances]
    return float(fitness(np.concatenate([rec["k"], nu])[None])[0])


@pytest.mark.parametrize("name", SMALL_PI_NAMES)
def test_small_pi_bag_scores_its_fitness_with_its_actuators_monitor_only(name):
    then = float(recorded(_bag(name))["health"]["fitness"])
    now = _small_pi_fitness_of_recorded_k(_bag(name), _small_pi_belief())
    assert now == pytest.approx(then, rel=FITNESS_OF_RECORDED_K_RTOL, abs=0)
    thesis = _small_pi_fitness_of_recorded_k(_bag(name), MonitorBelief.default())
    assert thesis > 3 * then  # another actuator's monitor does not explain it


@pytest.mark.parametrize("name", SMALL_PI_NAMES)
def test_small_pi_bag_is_judged_as_its_truth(name):
    rec = recorded(_bag(name))
    w = bags.read_window(_bag(name))
    a = assess_recorded(rec, k_true=w.k_true)
    faulty = bool(health.severity(w.k_true).max() > 0)
    assert (a.level > health.OK) == faulty
    if faulty:
        expected = health.assess(w.k_true).as_dict()["dominant_fault"]
        assert a.as_dict()["dominant_fault"] == expected


def test_small_pi_friction_bag_replays_with_its_actuator():
    path = _bag("small_pi_friction")
    rec = recorded(path)
    v = rec["values"]
    res = isolate(
        bags.read_window(path),
        belief=_small_pi_belief(),
        preset=v["preset"],
        seed=int(v["seed"]),
        weights=v["fitness_weighting"],
        nuisance=True,
        intervals=True,
    )
    assert res.fitness <= rec["health"]["fitness"] * (1 + REPLAY_FITNESS_SLACK)
    assert health.assess(res.k).as_dict()["dominant_fault"] == "friction"
