"""The simulator's lockstep bookkeeping per period, without ROS's own share, in CPU time.

``python benchmarks/lockstep_cost.py [--periods N] [--rounds R] [--reference-code DIR]`` plays
``N`` periods of what the simulator's loop does for lockstep besides waiting and DDS's own
reads and writes: encode the period's announcement (30 topics, 25 endpoints), read the
client's done from its bytes, record it in the gate, ask the gate whether it is open (twice:
before the done is taken and after), which admissions are due and which topics the client
reads next. The done is serialised by rclpy once per change of its counts (every 20th period a
request, as a mission's ticks send them), and its period is written into its bytes each period,
as the executive sends it. Each round runs in a process of its own on this checkout and, with
``--reference-code``, on another one (interleaved, this one first), and prints the mean CPU
time of the thread per period, in µs. Nothing is asserted; bad arguments give one line and
exit status 2.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

from sim_rtf import checkout, code_path

from bt_servicesim.cli import OneLineArgumentParser

TOPICS = 30
ENDPOINTS = 25
REQUEST_EVERY = 20


def build_parser() -> OneLineArgumentParser:
    parser = OneLineArgumentParser(
        prog="benchmarks/lockstep_cost.py",
        description="The simulator's lockstep bookkeeping per period, in CPU time.")
    parser.add_argument("--periods", type=int, default=20000, help="periods a round")
    parser.add_argument("--rounds", type=int, default=5, help="rounds per checkout")
    parser.add_argument("--reference-code", type=checkout, default=None, metavar="DIR",
                        help="another checkout to compare with, interleaved")
    parser.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    return parser


def play(periods: int) -> float:
    """Mean CPU µs per period of the bookkeeping (see the module docstring)."""
    from rclpy.serialization import serialize_message
    from servicesim_competition.msg import LockstepDone

    from servicesim_sim.lockstep.gate import LockstepGate
    from servicesim_sim.lockstep.message import AnnouncementBytes, DoneReader

    endpoints = [f"/servicesim/endpoint_{index:02d}" for index in range(ENDPOINTS)]
    messages = {f"/servicesim/topic_{index:02d}": 0 for index in range(TOPICS)}
    answers = dict.fromkeys(endpoints, 0)
    gate = LockstepGate(lag=1)
    gate.endpoints.update(endpoints)
    gate.announced(1)
    client = gate.join("executive")
    reader, encoder = DoneReader(), AnnouncementBytes()
    sent = dict.fromkeys(endpoints, 0)
    done = bytearray()
    started = time.thread_time()
    for period in range(2, periods + 2):
        for topic in messages:
            messages[topic] += 1
        encoder.encode(period=period, sim_time_ns=period * 100_000_000, messages=messages,
                       served=endpoints, answers=answers)
        gate.announced(period)
        gate.is_open()
        if period % REQUEST_EVERY == 2 or not done:
            endpoint = endpoints[period % ENDPOINTS]
            sent[endpoint] += 1
            gate.take(endpoint)
            done = bytearray(serialize_message(LockstepDone(
                client=client, endpoints=endpoints, requests=[sent[e] for e in endpoints])))
        done[12:20] = period.to_bytes(8, "little")
        said = reader.read(bytes(done))
        gate.done(said.client, said.period, said.requests, said.readings)
        gate.is_open()
        gate.due_admissions()
        gate.readers_next()
    return (time.thread_time() - started) / periods * 1e6


def round_on(code: Path, periods: int) -> float:
    environment = {**os.environ, "PYTHONPATH": code_path(code)}
    out = subprocess.run([sys.executable, __file__, "--worker", "--periods", str(periods)],
                         env=environment, cwd=code, check=True, capture_output=True, text=True)
    return float(out.stdout.strip())


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    if args.periods < 1 or args.rounds < 1:
        build_parser().error("--periods and --rounds: at least 1")
    if args.worker:
        print(f"{play(args.periods):.3f}")
        return 0
    this = Path(__file__).resolve().parent.parent
    codes = {"this checkout": this}
    if args.reference_code is not None:
        codes["reference"] = args.reference_code
    figures: dict[str, list[float]] = {name: [] for name in codes}
    for _ in range(args.rounds):
        for name, code in codes.items():
            figures[name].append(round_on(code, args.periods))
    load = " ".join(f"{value:.2f}" for value in os.getloadavg())
    print(f"{args.periods} periods, {args.rounds} round(s); load average {load}")
    for name, values in figures.items():
        print(f"  {name} ({codes[name]}): median {statistics.median(values):.1f} µs of CPU a "
              f"period ({min(values):.1f}-{max(values):.1f})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
