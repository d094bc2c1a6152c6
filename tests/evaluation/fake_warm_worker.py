"""A stand-in for ``python -m bt_servicesim.warm_worker``, no ROS: it speaks the worker's
protocol and misbehaves on request, by the episode's seed (``MODES``)."""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

MODES = {0: "report", 1: "garbage", 2: "hang", 3: "report", 4: "other run id", 5: "die"}


def report(episode: dict[str, object]) -> None:
    out = Path(str(episode["out"]))
    out.mkdir(parents=True, exist_ok=True)
    (out / "report.json").write_text(json.dumps({
        "status": "completed", "run_id": episode["run_id"], "completed": True, "score": 10.0,
        "sim_time_s": 100.0, "checkpoints": [], "penalties": {}, "wall_time_s": 0.1,
        "seed": episode["seed"], "world": "default", "executive": episode["executive"],
        "exit_code": 0, "failure": None}))


def main() -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument("--log-dir")
    parser.add_argument("--reply-fd", type=int)
    args = parser.parse_args()
    replies = os.fdopen(args.reply_fd, "w", buffering=1)
    replies.write(json.dumps({"ready": True, "ros_domain_id": 0}) + "\n")
    for line in sys.stdin:
        episode = json.loads(line)
        mode = MODES[int(episode["seed"])]
        if mode == "garbage":
            replies.write("this is not JSON\n")
        elif mode == "hang":
            time.sleep(3600)
        elif mode == "die":
            os.abort()
        elif mode == "other run id":
            replies.write(json.dumps({"run_id": "someone-else", "exit_code": 0,
                                      "goes_on": True}) + "\n")
        else:
            report(episode)
            replies.write(json.dumps({"run_id": episode["run_id"], "exit_code": 0,
                                      "goes_on": True}) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
