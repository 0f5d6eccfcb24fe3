"""Stands in for the campaign worker (scenarios/campaign/worker.py) in the executor tests: instant, scripted results, crashes and hangs.

The run's seed picks the behaviour: seed 7 crashes on its first attempt, seed 8 hangs on its first
attempt, seed 9 always crashes; every attempt appends "seed domain" to $FAKE_WORKER_LOG, and
$FAKE_WORKER_SLEEP seconds pass before a result.
"""

import json
import os
import sys
import time

run, out = json.loads(sys.argv[1]), sys.argv[2]
seed = run["seed"]
log = os.environ["FAKE_WORKER_LOG"]
with open(log, "a", encoding="utf-8") as handle:
    handle.write(f"{seed} {os.environ['ROS_DOMAIN_ID']} {os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE']}\n")
first_attempt = sum(line.split()[0] == str(seed) for line in open(log, encoding="utf-8")) == 1
print(f"fake worker for seed {seed}")
if seed == 9 or (seed == 7 and first_attempt):
    print("about to crash", flush=True)
    os._exit(3)
if seed == 8 and first_attempt:
    time.sleep(600)
time.sleep(float(os.environ.get("FAKE_WORKER_SLEEP", "0")))
with open(out, "w", encoding="utf-8") as handle:
    json.dump({"success": seed % 2 == 0, "status": "SUCCEEDED" if seed % 2 == 0 else "ABORTED",
               "failures": [] if seed % 2 == 0 else ["aborted: no plan"], "time_s": 10.0 + seed,
               "path_length": 2.0, "max_vel_x": 0.4, "collisions": seed % 3 == 1}, handle)
