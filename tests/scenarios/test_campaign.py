"""Scenario campaigns: the spec, the results file under crashes, hangs and kills, the statistics, and
lockstep determinism across sequential, parallel and Ray execution."""

import json
import math
import os
import signal
import subprocess
import sys
import time

import pytest

from simplebot_navigation.scenarios.campaign import execution
from simplebot_navigation.scenarios.campaign.cli import Progress, main, run_campaign
from simplebot_navigation.scenarios.campaign.execution import CampaignError, LocalExecutor, RayExecutor, domain_lease
from simplebot_navigation.scenarios.campaign.plot import hardest_runs, success_by_difficulty, summary_figure
from simplebot_navigation.scenarios.campaign.results import read_results
from simplebot_navigation.scenarios.campaign.spec import (SpecError, expand_worlds, plan, robot_body, spec_from_dict,
                                                          split_parameter_set)
from simplebot_navigation.scenarios.campaign.stats import (
    compare, fisher_p, summarize, summary_table, welch_p, wilson_interval)
from simplebot_navigation.sim.world_loader import load_world

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
FAKE_WORKER = (sys.executable, os.path.join(os.path.dirname(os.path.abspath(__file__)), "campaign_fake_worker.py"))


# -- spec ------------------------------------------------------------------------------------------
def test_parameter_sets_are_checked_when_the_campaign_is_planned():
    good = spec_from_dict({"worlds": "lab", "params": ["default", "TebLocalPlannerROS.max_vel_x=0.3"]})
    assert [run.params for run in plan(good)[::6]] == [(), ("TebLocalPlannerROS.max_vel_x=0.3",)]
    bad = spec_from_dict({"worlds": "lab", "params": ["TebLocalPlannerROS.max_vel=1"]})
    with pytest.raises(SpecError, match="params: 'TebLocalPlannerROS.max_vel=1': --set: .*did you mean"):
        plan(bad)


def test_the_cross_product_and_generated_families():
    assert expand_worlds(["forest:0-2", "lab", "maps/a.yaml"]) == ["forest:0", "forest:1", "forest:2", "lab",
                                                                    "maps/a.yaml"]
    spec = spec_from_dict({"worlds": "lab", "seeds": "0-1", "robots": "box,round", "goals": "library,lab",
                           "params": ["default", {"TebLocalPlannerROS.max_vel_x": 0.3}]})
    runs = plan(spec)
    assert len(runs) == 1 * 2 * 2 * 2 * 2
    assert runs[0].to_dict() == {"world": "lab", "seed": 0, "robot": "box", "params": [], "goal": "library"}
    assert runs[-1].params == ("TebLocalPlannerROS.max_vel_x=0.3",)
    assert len({run.key for run in runs}) == len(runs)
    assert len(plan(spec_from_dict({"worlds": "lab", "goals": "all"}))) == 6  # every goal of the lab


def test_a_round_body_of_any_radius_and_the_shipped_narrow_passage_set():
    assert robot_body("round:0.25") == ("round", 0.25) and robot_body("box") == ("box", 0.3)
    spec = spec_from_dict({"worlds": "forest:0", "robots": "round:0.25",
                           "params": ["tight TebLocalPlannerROS.max_vel_x=1.0"]})
    (run,) = plan(spec)
    assert run.robot == "round:0.25" and run.params == ("tight", "TebLocalPlannerROS.max_vel_x=1.0")
    assert split_parameter_set(run.params) == (("tight",), ["TebLocalPlannerROS.max_vel_x=1.0"])
    with pytest.raises(SpecError, match="params: 'tight TebLocalPlannerROS.max_vel=1.0': --set: .*did you mean"):
        plan(spec_from_dict({"worlds": "lab", "params": ["tight TebLocalPlannerROS.max_vel=1.0"]}))


@pytest.mark.parametrize("data, message", [
    ({"seeds": 0}, "worlds: missing"),
    ({"worlds": "lab", "seed": 1}, "seed: unknown key"),
    ({"worlds": "lab", "seeds": "3-1"}, "seeds: range '3-1' runs backwards"),
    ({"worlds": "lab", "seeds": "x"}, "seeds: 'x' is not an integer"),
    ({"worlds": "lab", "robots": "tank"}, "robots: unknown body 'tank'"),
    ({"worlds": "lab", "robots": "box:0.3"}, "robots: unknown body 'box:0.3'"),
    ({"worlds": "lab", "robots": "round:5"}, r"robots: 'round:5': the radius must lie in \[0.1, 1.0\] m"),
    ({"worlds": "lab", "params": ["narrow"]}, r"params\[0\]: 'narrow' is not K=V nor a shipped parameter set"),
    ({"worlds": "lab", "params": [["max_vel_x"]]}, r"params\[0\]: 'max_vel_x' is not K=V"),
    ({"worlds": "lab", "run_timeout": -1}, "run_timeout: expected a positive number"),
    ({"worlds": "lab,lab"}, "worlds: listed twice"),
])
def test_a_malformed_spec_names_the_key(data, message):
    with pytest.raises(SpecError, match=message):
        spec_from_dict(data)


@pytest.mark.parametrize("data, message", [
    ({"worlds": "atlantis"}, "worlds: atlantis .box robot.: unknown world 'atlantis'"),
    ({"worlds": "lab", "goals": "kitchen"}, "goals: world lab: lab.yaml: no goal named 'kitchen'"),
    ({"worlds": "empty"}, "goals: world empty: world 'empty' .* has no goals"),
])
def test_worlds_and_goals_are_checked_before_anything_runs(data, message):
    with pytest.raises(SpecError, match=message):
        plan(spec_from_dict(data))


def test_the_command_names_the_bad_flag_or_key(tmp_path, capsys):
    spec = tmp_path / "spec.yaml"
    spec.write_text("worlds: [lab]\nrobot: box\n")
    for argv, message in (([str(spec), "--out", str(tmp_path / "r.jsonl")], "robot: unknown key in"),
                          (["--worlds", "lab", "--seeds", "2-1", "--out", "r.jsonl"], "seeds: range '2-1'"),
                          (["--worlds", "lab", "--jobs", "0", "--out", "r.jsonl"], "--jobs must be >= 1"),
                          (["--worlds", "lab", "--jobs", "1000", "--out", "r.jsonl"], "--jobs must be at most 256"),
                          (["--worlds", "lab", "--seeds", "0-99999999999", "--out", "r.jsonl"],
                           "seeds: '0-99999999999' holds more than 10000 values"),
                          (["--worlds", "forest:0-9999", "--seeds", "0-99", "--out", "r.jsonl"],
                           "10000 worlds x 100 seeds x 1 robots x 1 parameter sets is 1000000 runs, more than 100000"),
                          (["--worlds", "lab", "--out", "/nonexistent/r.jsonl"], "directory /nonexistent does not exist"),
                          (["--worlds", "lab"], "--out is required")):
        with pytest.raises(SystemExit) as exit_:
            main(argv)
        assert exit_.value.code == 2
        assert message in capsys.readouterr().err.splitlines()[-1]


def test_a_ray_address_where_nothing_answers_is_an_error_not_a_hang(tmp_path, capsys):
    pytest.importorskip("ray")
    assert main(["--worlds", "lab", "--goals", "library", "--out", str(tmp_path / "r.jsonl"),
                 "--ray", "127.0.0.1:1"]) == 2
    assert "--ray 127.0.0.1:1: nothing answers there within 30 s" in capsys.readouterr().err
    assert not (tmp_path / "r.jsonl").exists()


# -- executors and the results file, with a scripted worker ----------------------------------------
@pytest.fixture
def fake_worker(tmp_path, monkeypatch):
    log = tmp_path / "attempts.log"
    monkeypatch.setenv("FAKE_WORKER_LOG", str(log))
    return log


def test_crashes_and_hangs_are_recorded_with_their_log_and_retried_once(tmp_path, fake_worker, capsys):
    spec = spec_from_dict({"worlds": "lab", "goals": "library", "seeds": "6-9", "run_timeout": 4})
    out = tmp_path / "results.jsonl"
    records = run_campaign(spec, str(out), LocalExecutor(2, command=FAKE_WORKER))
    final = {r["seed"]: r for r in records}
    assert {seed: (r["status"], r["attempt"]) for seed, r in final.items()} == {
        6: ("SUCCEEDED", 1), 7: ("ABORTED", 2), 8: ("SUCCEEDED", 2), 9: ("ERROR", 2)}
    header, attempts = read_results(str(out))
    assert header["spec"]["seeds"] == [6, 7, 8, 9]
    errors = {(r["seed"], r["attempt"]): r for r in attempts if r["error"]}
    assert set(errors) == {(7, 1), (8, 1), (9, 1), (9, 2)}
    assert errors[(7, 1)]["error"] == "crashed: exit code 3" and "about to crash" in errors[(7, 1)]["log_tail"]
    assert errors[(8, 1)]["error"].startswith("hung: no result within the 4 s run timeout")
    assert "fake worker for seed 8" in errors[(8, 1)]["log_tail"]
    # Each attempt had a domain of its own, never this process's, and localhost-only discovery.
    lines = [line.split() for line in fake_worker.read_text().splitlines()]
    assert len(lines) == 7 and all(rng == "LOCALHOST" and dom != os.environ["ROS_DOMAIN_ID"] for _, dom, rng in lines)
    assert "FAIL ERROR" in capsys.readouterr().err
    # Resuming a finished campaign runs nothing again.
    run_campaign(spec, str(out), LocalExecutor(2, command=FAKE_WORKER), resume=True)
    assert len(fake_worker.read_text().splitlines()) == 7


def test_concurrent_runs_never_share_a_domain(tmp_path, monkeypatch):
    monkeypatch.setattr(execution, "LOCK_FOLDER", str(tmp_path))  # no campaign of this host in the way
    with domain_lease(40, avoid=41) as a, domain_lease(40, avoid=41) as b, domain_lease(40, avoid=41) as c:
        assert (a, b, c) == (40, 42, 43)  # taken in order from the first, the campaign's own id skipped
    with domain_lease(101, avoid=None) as a, domain_lease(101, avoid=None) as b:
        assert (a, b) == (101, 0)


def test_without_ray_the_error_says_how_to_install_it(monkeypatch):
    monkeypatch.setitem(sys.modules, "ray", None)
    with pytest.raises(CampaignError, match=r"--ray: Ray is not installed; pip install -e '.\[cluster\]'"):
        RayExecutor("auto")


CAMPAIGN_SCRIPT = """
import sys
from simplebot_navigation.scenarios.campaign.cli import run_campaign
from simplebot_navigation.scenarios.campaign.execution import LocalExecutor
from simplebot_navigation.scenarios.campaign.spec import spec_from_dict
spec = spec_from_dict({"worlds": "lab", "goals": "library", "seeds": "0-5"})
run_campaign(spec, sys.argv[1], LocalExecutor(1, command=tuple(sys.argv[2:])), resume=True)
"""


def test_a_killed_campaign_loses_no_finished_run_and_resume_completes_it(tmp_path, fake_worker):
    out = tmp_path / "results.jsonl"
    env = dict(os.environ, PYTHONPATH=REPO, FAKE_WORKER_SLEEP="1.0")
    campaign = subprocess.Popen([sys.executable, "-c", CAMPAIGN_SCRIPT, str(out), *FAKE_WORKER], env=env,
                                start_new_session=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and (not out.exists() or len(out.read_text().splitlines()) < 3):
        time.sleep(0.1)
    os.killpg(campaign.pid, signal.SIGKILL)  # the campaign and the worker it is waiting on
    campaign.wait()
    _, before = read_results(str(out))
    assert 2 <= len(before) < 6
    with open(out, "a", encoding="utf-8") as handle:
        handle.write('{"world": "lab", "se')  # a record cut short by the kill
    started = len(fake_worker.read_text().splitlines())
    spec = spec_from_dict({"worlds": "lab", "goals": "library", "seeds": "0-5"})
    records = run_campaign(spec, str(out), LocalExecutor(1, command=FAKE_WORKER), resume=True)
    assert sorted(r["seed"] for r in records) == list(range(6))
    _, after = read_results(str(out))
    assert after[:len(before)] == before                     # nothing finished was lost or rewritten
    assert len(after) == 6                                   # and nothing finished was run again
    rerun = [int(line.split()[0]) for line in fake_worker.read_text().splitlines()[started:]]
    assert sorted(rerun) == sorted(set(range(6)) - {r["seed"] for r in before})


def test_resume_keeps_a_whole_last_record_that_lost_its_newline(tmp_path, fake_worker):
    out = tmp_path / "results.jsonl"
    spec = spec_from_dict({"worlds": "lab", "goals": "library", "seeds": "0-2"})
    run_campaign(spec, str(out), LocalExecutor(1, command=FAKE_WORKER))
    out.write_bytes(out.read_bytes().rstrip(b"\n"))          # a whole record, its newline lost
    attempts = len(fake_worker.read_text().splitlines())
    records = run_campaign(spec, str(out), LocalExecutor(1, command=FAKE_WORKER), resume=True)
    assert sorted(r["seed"] for r in records) == [0, 1, 2]
    assert len(fake_worker.read_text().splitlines()) == attempts   # nothing run again
    _, kept = read_results(str(out))
    assert sorted(r["seed"] for r in kept) == [0, 1, 2] and out.read_bytes().endswith(b"\n")


# -- statistics ------------------------------------------------------------------------------------
def test_wilson_interval_on_known_values():
    assert wilson_interval(5, 10) == pytest.approx((0.2366, 0.7634), abs=1e-4)
    assert wilson_interval(0, 10) == pytest.approx((0.0, 0.2775), abs=1e-4)
    assert wilson_interval(10, 10) == pytest.approx((0.7225, 1.0), abs=1e-4)
    assert wilson_interval(81, 263) == pytest.approx((0.2553, 0.3662), abs=1e-4)
    assert all(math.isnan(v) for v in wilson_interval(0, 0))


def test_fisher_and_welch_on_known_values():
    assert fisher_p((8, 10), (2, 10)) == pytest.approx(0.02301, abs=1e-4)
    assert fisher_p((3, 4), (1, 4)) == pytest.approx(0.4857, abs=1e-4)
    # t = -3 / sqrt(0.5 + 2) = -1.897 with 5.88 Welch-Satterthwaite degrees of freedom
    assert welch_p([1, 2, 3, 4, 5], [2, 4, 6, 8, 10]) == pytest.approx(0.1075, abs=1e-3)
    assert math.isnan(welch_p([1.0], [2.0, 3.0]))


def record(seed, success, time_s, params=(), family="lab"):
    return {"world": family, "family": family, "seed": seed, "robot": "box", "params": list(params), "goal": "g",
            "success": success, "time_s": time_s, "path_length": 4.0, "max_vel_x": 0.4, "collisions": 0,
            "failures": [] if success else ["timeout: no result within the 30 s budget"], "error": None}


def test_summary_and_comparison_of_two_parameter_sets():
    a = [record(i, i < 2, 20.0 + i) for i in range(10)]
    b = [record(i, i < 8, 10.0 + i % 3, params=("max_vel_x=0.6",)) for i in range(10)]
    (group,) = summarize(a)
    assert (group.runs, group.successes, group.mean_time_s, group.time_ratio) == (10, 2, 20.5, pytest.approx(2.05))
    assert group.failures == {"timeout": 8}
    (c,) = compare(a, b)
    assert c.group == ("lab", "box", "default -> max_vel_x=0.6")
    struck = [{**r, "collisions": 1, "struck_standing": 2} for r in b]
    header, _, row = summary_table(summarize(struck)).splitlines()
    assert header.split()[8:10] == ["coll", "struck"] and row.split()[8:10] == ["10", "20"]
    assert c.rate_difference == pytest.approx(0.6) and c.rate_p == pytest.approx(0.02301, abs=1e-4)
    assert c.mean_a == 20.5 and c.time_p < 0.05


# -- real runs: lockstep determinism across executors ----------------------------------------------
DETERMINED = ("success", "status", "time_s", "path_length", "collisions", "final", "min_clearance", "replans",
              "recoveries", "failures")
#: four runs: enough for two workers (or Ray's two CPUs) to interleave and still finish in any order
SHORT_CAMPAIGN = {"worlds": "empty", "goals": ["1,0,0", "0.8,0.4,0.5"], "seeds": "0-1", "run_timeout": 600}


def outcomes(records):
    return {(r["seed"], r["goal"]): {k: r[k] for k in DETERMINED} for r in records}


@pytest.fixture(scope="module")
def sequential(tmp_path_factory):
    out = tmp_path_factory.mktemp("sequential") / "results.jsonl"
    records = run_campaign(spec_from_dict(SHORT_CAMPAIGN), str(out), LocalExecutor(1))
    assert len(records) == 4 and all(r["success"] for r in records), [r["failures"] for r in records]
    return outcomes(records)


@pytest.mark.e2e
@pytest.mark.timeout(1800)
def test_two_workers_give_the_sequential_results(sequential, tmp_path):
    records = run_campaign(spec_from_dict(SHORT_CAMPAIGN), str(tmp_path / "r.jsonl"), LocalExecutor(2))
    assert outcomes(records) == sequential


@pytest.mark.e2e
@pytest.mark.timeout(1800)
def test_a_local_ray_gives_the_sequential_results(sequential, tmp_path, monkeypatch):
    import ray  # in the test extras, so CI runs this on an embedded Ray

    # Ray starts its workers niced, so on a loaded machine (CI beside busy loops) they wait for every other
    # process: minutes instead of seconds. The raylet reads this from its environment.
    monkeypatch.setenv("RAY_worker_niceness", "0")
    ray.init(num_cpus=2, include_dashboard=False)
    try:
        records = run_campaign(spec_from_dict(SHORT_CAMPAIGN), str(tmp_path / "r.jsonl"), RayExecutor("local"))
    finally:
        ray.shutdown()
    assert outcomes(records) == sequential
    assert json.loads((tmp_path / "r.jsonl").read_text().splitlines()[0])["spec"]["seeds"] == list(range(2))


def test_the_summary_figure_and_the_hardest_runs(tmp_path):
    records = [record(i, i < 7, 20.0 + i) for i in range(10)]
    goal = {"x": 8.5, "y": 5.0, "yaw": 0.0, "status": "ABORTED", "reason": "", "budget_s": 60.0,
            "straight_line": 9.9, "min_clearance": None, "replans": 1, "recoveries": 0, "cycle_p95_ms": 12.0,
            "cycles_missed": 0, "final": [4.0, 0.0, 0.0], "position_error": 5.0, "yaw_error": 0.0, "wall_s": 9.0,
            "trajectory": [[2.0, 0.0, 0.0, 0.0], [9.0, 4.0, 0.0, 0.0]]}
    records[9] |= goal
    records[0] |= goal | {"status": "SUCCEEDED"}
    summary_figure(str(tmp_path / "fig.png"), records)
    assert (tmp_path / "fig.png").read_bytes()[:4] == b"\x89PNG"
    files = hardest_runs(str(tmp_path / "fig.png"), records)
    assert files == [str(tmp_path / "fig_hardest_1.png"), str(tmp_path / "fig_hardest_2.png")]
    assert all(os.path.getsize(f) > 10_000 for f in files)


def test_success_by_difficulty_bins_the_forest_worlds_by_their_narrowest_passage(tmp_path):
    passages = {seed: load_world(f"forest:{seed}").extra["cspace"]["narrowest_passage"] for seed in range(8)}
    narrow = sorted(passages, key=passages.get)[:2]   # the two hardest worlds fail
    records = [record(0, seed not in narrow, 40.0, family="forest") | {"world": f"forest:{seed}", "robot": "round:0.25"}
               for seed in range(8)] + [record(0, False, 20.0)]   # a lab run has no C-space difficulty
    rows = success_by_difficulty(records)
    assert sum(n for *_, n, _ in rows) == 8
    assert rows[0][2:4] == (0, 2) and all(ok == n for _, _, ok, n, _ in rows[1:])
    assert rows[0][0] == min(passages.values()) and rows[-1][1] == max(passages.values())
    summary_figure(str(tmp_path / "fig.png"), records)
    assert (tmp_path / "fig.png").read_bytes()[:4] == b"\x89PNG"
    everything = [r | {"success": True, "failures": []} for r in records[:8]] * 5   # 10/10 a quartile: rounding puts
    # the interval's top a hair below the rate
    summary_figure(str(tmp_path / "all.png"), everything)
    assert (tmp_path / "all.png").read_bytes()[:4] == b"\x89PNG"


def test_progress_goes_through_tqdm_when_it_is_installed(monkeypatch):
    class Bar:
        def __init__(self, total, initial, **kw):
            self.total, self.n, self.lines, self.postfix = total, initial, [], ""

        def write(self, line):
            self.lines.append(line)

        def set_postfix_str(self, text):
            self.postfix = text

        def close(self):
            pass

    monkeypatch.setitem(sys.modules, "tqdm", type(sys)("tqdm"))
    sys.modules["tqdm"].tqdm = Bar
    progress = Progress(total=3, done=1, failed=0)
    progress.finished(record(4, False, 12.0) | {"status": "ABORTED"}, retrying=False, running=1)
    assert (progress.bar.n, progress.bar.postfix) == (2, "failed 1, running 1")
    assert progress.bar.lines == ["[2/3] lab seed 4 box default goal g: FAIL ABORTED in 12.0 s sim "
                                  "(timeout: no result within the 30 s budget)"]
