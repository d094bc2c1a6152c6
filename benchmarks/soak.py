"""Many missions back to back: what is left behind, and whether anything grows.

``python benchmarks/soak.py [--episodes N] [--jobs 1|2] [--speed X] [--seed S]
[--executive bt|baseline] [--episode-timeout S] [--keep DIR]`` runs ``N`` episodes (default
200), ``--jobs`` at a time, each a ``python -m bt_servicesim.run --headless --speed X`` on a
seeded random task (episode n plays seed S + n), and prints, at the start and at the end:

* processes of ours: every ``servicesim_sim`` and ``bt_servicesim.run`` process on the machine,
  how many of them are orphans (their parent is gone: re-parented to init), and, at the end,
  any child of this benchmark still running;
* ``/dev/shm``: the Fast DDS entries (``fastdds_*``), their size, and the shared-memory segments
  among them whose owner is alive or dead (Fast DDS holds a lock on each live segment's ``_el``
  file; a dead owner's segment stays until someone removes it);

and at the end, over the episodes: outcomes and exit codes; the wall time; the peak resident
memory (VmHWM) of the run and of its simulator in the first and the last episode and the
largest; the CPU time of each episode (run and simulator together); the shared-memory segments
the episodes' own processes created and how many of them were still there once those processes
had ended; and the simulators that outlived their run (this benchmark adopts orphans, as a
child subreaper, to see how they end).

Figures are wall-clock on this machine and vary with its load (other runs and tests on the
machine share ``/dev/shm`` and the process table); nothing is asserted. Ctrl-C stops the
episodes under way and still prints the figures. Bad arguments give one line and exit status 2.
"""

from __future__ import annotations

import argparse
import contextlib
import ctypes
import fcntl
import math
import os
import re
import shutil
import signal
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

from ros_harness import isolate

from bt_servicesim.cli import EXIT_BAD_INPUT, OneLineArgumentParser
from bt_servicesim.evaluation.process_tree import descendants, start_time, stop_process_tree
from bt_servicesim.mission.report import read_report
from bt_servicesim.mission.stopping import StopSignals, Terminated, parent_death_signal

SHM = Path("/dev/shm")
SEGMENT_LOCK = re.compile(r"^(fastdds_[0-9a-f]{16})_el$")
OUR_PROGRAMS = ("servicesim_sim", "bt_servicesim.run")
PR_SET_CHILD_SUBREAPER = 36  # from <linux/prctl.h>
SAMPLE_S = 0.2  # wall seconds between looks at an episode's processes
GONE_WAIT_S = 15.0  # wall seconds an episode's simulator gets to end after its run
NEW_SEGMENT_S = 5.0  # a segment lock younger than this may not be locked yet: not judged


def build_parser() -> OneLineArgumentParser:
    parser = OneLineArgumentParser(prog="benchmarks/soak.py",
                                   description="Many missions back to back: what is left.")
    parser.add_argument("--episodes", type=int, default=200,
                        help="episodes to run (default 200)")
    parser.add_argument("--jobs", type=int, choices=(1, 2), default=1,
                        help="episodes at once: 1 or 2 (default 1)")
    parser.add_argument("--speed", type=float, default=50.0,
                        help="sim speed of every episode (default 50)")
    parser.add_argument("--seed", type=int, default=0,
                        help="seed of the first episode; episode n plays seed+n (default 0)")
    parser.add_argument("--executive", choices=("bt", "baseline"), default="bt",
                        help="the executive of every episode (default bt)")
    parser.add_argument("--episode-timeout", type=float, default=600.0,
                        help="wall seconds before an episode is stopped (default 600)")
    parser.add_argument("--keep", type=Path,
                        help="keep the run directories here (default: a temporary directory, "
                             "removed at the end)")
    return parser


def check(args: argparse.Namespace) -> str | None:
    """What is wrong with the arguments, as one line; None if nothing."""
    episodes, speed, seed = args.episodes, args.speed, args.seed
    timeout, keep = args.episode_timeout, args.keep
    if episodes < 1:
        return f"--episodes {episodes}: must be 1 or more"
    if not (math.isfinite(speed) and speed >= 0.0):
        return f"--speed {speed}: must be a finite number, 0 or more"
    if seed < 0:
        return f"--seed {seed}: must be 0 or more"
    if not (math.isfinite(timeout) and 0.0 < timeout <= 1e6):
        return f"--episode-timeout {timeout}: must be more than 0 and at most 1000000"
    if keep is not None and keep.exists() and not keep.is_dir():
        return f"--keep {keep}: exists and is not a directory"
    return None


# ------------------------------------------------------------------ the machine


def processes_of_ours() -> dict[int, tuple[str, int]]:
    """Every running ``servicesim_sim`` / ``bt_servicesim.run`` of this user: pid to (program,
    parent pid)."""
    found = {}
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            if entry.stat().st_uid != os.getuid():
                continue
            arguments = (entry / "cmdline").read_bytes().split(b"\0")
            parent = int((entry / "stat").read_text().rsplit(")", 1)[1].split()[1])
            state = (entry / "stat").read_text().rsplit(")", 1)[1].split()[0]
        except (OSError, IndexError, ValueError):
            continue
        if state == "Z":
            continue
        for program in OUR_PROGRAMS:
            if program.encode() in arguments[1:3]:  # python -m <program>
                found[int(entry.name)] = (program, parent)
    return found


def describe_processes(when: str) -> None:
    found = processes_of_ours()
    counts = Counter(program for program, _ in found.values())
    orphans = sorted(pid for pid, (_, parent) in found.items()
                     if parent == 1 or not Path(f"/proc/{parent}").exists())
    mine = [pid for pid in descendants(os.getpid()) if start_time(pid) is not None]
    listed = ", ".join(f"{counts[program]} {program}" for program in OUR_PROGRAMS)
    print(f"{when}: processes of ours running on this machine: {listed}; orphans (parent "
          f"gone): {len(orphans)}{' ' + str(orphans) if orphans else ''}; children of this "
          f"benchmark: {len(mine)}")


def segment_locks() -> dict[str, Path]:
    """Each shared-memory segment's name to its ``_el`` lock file."""
    try:
        names = os.listdir(SHM)
    except OSError:
        return {}
    return {match.group(1): SHM / name for name in names
            if (match := SEGMENT_LOCK.match(name))}


def owner_alive(lock: Path) -> bool | None:
    """Whether a live process holds the segment's lock; None when that cannot be judged yet
    (the file is gone, or so new that its owner may not have locked it)."""
    try:
        if time.time() - lock.stat().st_mtime < NEW_SEGMENT_S:
            return None
        with lock.open("rb") as handle:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)  # released on close
    except BlockingIOError:
        return True
    except OSError:
        return None
    return False


def describe_shm(when: str) -> None:
    try:
        entries = [SHM / name for name in os.listdir(SHM) if name.startswith("fastdds_")]
    except OSError:
        print(f"{when}: /dev/shm cannot be read")
        return
    size = 0
    for entry in entries:
        with contextlib.suppress(OSError):
            size += entry.stat().st_blocks * 512
    judged = Counter(owner_alive(lock) for lock in segment_locks().values())
    ports = sum(entry.name.startswith("fastdds_port") for entry in entries)
    print(f"{when}: /dev/shm fastdds_* entries: {len(entries)} ({size / 1e6:.1f} MB in use); "
          f"segments: {judged[True]} of live owners, {judged[False]} of dead owners, "
          f"{judged[None]} too new to judge; port files: {ports}")


# ------------------------------------------------------------------ one episode


@dataclass
class Episode:
    number: int
    seed: int
    out: Path
    returncode: int | None = None
    wall_s: float = 0.0
    cpu_s: float | None = None
    report: dict[str, object] | None = None
    peak_kb: dict[str, int] = field(default_factory=dict)  # "run" / "simulator" to VmHWM
    segments: dict[str, set[str]] = field(default_factory=dict)  # kind to segment names
    left: dict[str, list[str]] = field(default_factory=dict)  # kind to segments still there
    outlived: list[str] = field(default_factory=list)  # how simulators that outlived it ended
    stopped: bool = False


def own_segments(pid: int) -> set[str]:
    """The segments whose lock ``pid`` holds open (its own participant's)."""
    found: set[str] = set()
    try:
        descriptors = os.listdir(f"/proc/{pid}/fd")
    except OSError:
        return found
    for descriptor in descriptors:
        try:
            target = os.readlink(f"/proc/{pid}/fd/{descriptor}")
        except OSError:
            continue
        match = SEGMENT_LOCK.match(os.path.basename(target))
        if match and target.startswith(str(SHM)):
            found.add(match.group(1))
    return found


def peak_rss_kb(pid: int) -> int | None:
    try:
        for line in Path(f"/proc/{pid}/status").read_text().splitlines():
            if line.startswith("VmHWM:"):
                return int(line.split()[1])
    except (OSError, ValueError, IndexError):
        return None
    return None


def kind_of(pid: int, run_pid: int) -> str | None:
    if pid == run_pid:
        return "run"
    try:
        arguments = Path(f"/proc/{pid}/cmdline").read_bytes().split(b"\0")
    except OSError:
        return None
    return "simulator" if b"servicesim_sim" in arguments[1:3] else None  # not yet exec'd


class Soak:
    def __init__(self, args: argparse.Namespace, directory: Path) -> None:
        self.args = args
        self.directory = directory
        self.stopping = threading.Event()
        self.episodes: list[Episode] = []
        self.lock = threading.Lock()
        self.die_with_us = parent_death_signal(os.getpid())  # no orphan if this is killed

    def run_episode(self, number: int) -> None:
        args = self.args
        seed = args.seed + number
        episode = Episode(number=number, seed=seed, out=self.directory / str(number))
        command = [sys.executable, "-m", "bt_servicesim.run", "--headless", "--speed",
                   repr(args.speed), "--seed", str(seed), "--executive", args.executive,
                   "--out", str(episode.out), "--run-id", f"soak-{os.getpid()}-{number}"]
        started = time.monotonic()
        deadline = started + args.episode_timeout
        with (self.directory / f"{number}.log").open("wb") as log:
            process = subprocess.Popen(command, stdout=log, stderr=subprocess.STDOUT,
                                       stdin=subprocess.DEVNULL, start_new_session=True,
                                       preexec_fn=self.die_with_us)
        family: dict[int, tuple[str, int]] = {}  # pid to (kind, start time)
        while True:
            self._sample(process.pid, episode, family)
            pid, status, usage = os.wait4(process.pid, os.WNOHANG)
            if pid:
                process.returncode = os.waitstatus_to_exitcode(status)
                episode.cpu_s = usage.ru_utime + usage.ru_stime  # the run and what it reaped
                break
            if self.stopping.is_set() or time.monotonic() > deadline:
                episode.stopped = True
                stop_process_tree(process)
                break
            time.sleep(SAMPLE_S)
        episode.returncode = process.returncode
        episode.wall_s = time.monotonic() - started
        self._after(episode, family)
        episode.report = read_report(episode.out / "report.json")
        with self.lock:
            self.episodes.append(episode)

    def _sample(self, run_pid: int, episode: Episode, family: dict[int, tuple[str, int]]) -> None:
        for pid in (run_pid, *descendants(run_pid)):
            kind = kind_of(pid, run_pid)
            started = start_time(pid)
            if kind is None or started is None:
                continue
            family[pid] = (kind, started)
            peak = peak_rss_kb(pid)
            if peak is not None:
                episode.peak_kb[kind] = max(episode.peak_kb.get(kind, 0), peak)
            episode.segments.setdefault(kind, set()).update(own_segments(pid))

    def _after(self, episode: Episode, family: dict[int, tuple[str, int]]) -> None:
        """Wait for the episode's other processes to end (reaping those adopted), then see
        which of their segments are still there."""
        deadline = time.monotonic() + GONE_WAIT_S
        for pid, (kind, started) in family.items():
            if kind == "run":
                continue
            while start_time(pid) == started and time.monotonic() < deadline:
                try:
                    reaped, status = os.waitpid(pid, os.WNOHANG)
                except ChildProcessError:  # not ours to reap: its run did, or will
                    time.sleep(0.05)
                    continue
                if reaped:
                    code = os.waitstatus_to_exitcode(status)
                    episode.outlived.append(f"killed by {signal.Signals(-code).name}"
                                            if code < 0 else f"exit code {code}")
                    break
                time.sleep(0.05)
        for kind, names in episode.segments.items():
            episode.left[kind] = sorted(name for name in names
                                        if (SHM / name).exists() or (SHM / f"{name}_el").exists())


# ------------------------------------------------------------------ the figures


def minutes(seconds: float) -> str:
    return f"{int(seconds // 60)}m{seconds % 60:04.1f}s"


def print_episodes(episodes: list[Episode], wall_s: float) -> None:
    episodes = sorted(episodes, key=lambda episode: episode.number)
    if not episodes:
        print("no episode ran")
        return
    completed = sum(bool(episode.report and episode.report.get("completed"))
                    for episode in episodes)
    codes = Counter(episode.returncode for episode in episodes)
    stopped = sum(episode.stopped for episode in episodes)
    walls = [episode.wall_s for episode in episodes]
    print(f"episodes: {len(episodes)} ({completed} completed, {len(episodes) - completed} "
          f"not; exit codes {dict(sorted(codes.items(), key=str))}; stopped by this "
          f"benchmark: {stopped}); wall time {minutes(wall_s)} in all, per episode median "
          f"{statistics.median(walls):.1f} s, max {max(walls):.1f} s")
    for kind in ("run", "simulator"):
        peaks = [episode.peak_kb[kind] / 1024 for episode in episodes if kind in episode.peak_kb]
        if peaks:
            print(f"peak RSS of the {kind} per episode: first {peaks[0]:.0f} MB, last "
                  f"{peaks[-1]:.0f} MB, max {max(peaks):.0f} MB, median "
                  f"{statistics.median(peaks):.0f} MB")
    cpus = [(episode.cpu_s, float(sim_s)) for episode in episodes
            if episode.cpu_s is not None and episode.report
            and isinstance(sim_s := episode.report.get("sim_time_s"), int | float) and sim_s > 0]
    if cpus:
        print(f"CPU per episode (run and simulator): median "
              f"{statistics.median(cpu for cpu, _ in cpus):.1f} s, first {cpus[0][0]:.1f} s, "
              f"last {cpus[-1][0]:.1f} s; per sim second of the task (start-up included): median "
              f"{statistics.median(1000 * cpu / sim for cpu, sim in cpus):.1f} ms")
    for kind in ("run", "simulator"):
        made = sum(len(episode.segments.get(kind, ())) for episode in episodes)
        left = [name for episode in episodes for name in episode.left.get(kind, ())]
        print(f"shared-memory segments of the episodes' {kind} processes: {made} created, "
              f"{len(left)} still in /dev/shm after the process ended")
    for episode in episodes:
        for kind, names in episode.left.items():
            if names:
                print(f"  episode {episode.number} (seed {episode.seed}, exit code "
                      f"{episode.returncode}): the {kind} left {', '.join(names)}")
    outlived = Counter(how for episode in episodes for how in episode.outlived)
    print(f"simulators that outlived their run: {sum(outlived.values())}"
          f"{' ' + str(dict(outlived)) if outlived else ''}")


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    problem = check(args)
    if problem is not None:
        print(f"{parser.prog}: error: {problem}", file=sys.stderr)
        return EXIT_BAD_INPUT
    domain = isolate()
    ctypes.CDLL(None).prctl(PR_SET_CHILD_SUBREAPER, 1, 0, 0, 0)
    directory = args.keep or Path(tempfile.mkdtemp(prefix="soak-"))
    directory.mkdir(parents=True, exist_ok=True)
    print(f"soak: {args.episodes} episodes of {args.executive} at speed {args.speed:g}, "
          f"{args.jobs} at once, seeds {args.seed}..{args.seed + args.episodes - 1}; "
          f"discovery {os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE']}, this benchmark's ROS "
          f"domain {domain} (each run claims its own), {os.cpu_count()} CPUs, "
          f"FASTDDS_BUILTIN_TRANSPORTS={os.environ.get('FASTDDS_BUILTIN_TRANSPORTS', '(unset)')}")
    describe_processes("start")
    describe_shm("start")
    soak = Soak(args, directory)
    started = time.monotonic()
    numbers = iter(range(args.episodes))
    workers: list[threading.Thread] = []

    def work() -> None:
        for number in numbers:  # shared: each number goes to one worker
            if soak.stopping.is_set():
                return
            soak.run_episode(number)

    with StopSignals() as stops:  # Ctrl-C, SIGTERM, SIGHUP: stop the episodes, print the figures
        try:
            for _ in range(args.jobs):
                workers.append(threading.Thread(target=work, daemon=True))
                workers[-1].start()
            while any(worker.is_alive() for worker in workers):
                time.sleep(0.5)  # not join(timeout): Python 3.11 loses a thread whose join a
                #                  signal interrupted, and the join after it returns at once
            stops.hold()
        except (KeyboardInterrupt, Terminated) as stop:
            stops.hold(stop)
            soak.stopping.set()
            for worker in workers:
                worker.join()
        if stops.first is not None:
            print(f"stopped by {signal.Signals(stops.first).name}")
        print_episodes(soak.episodes, time.monotonic() - started)
        describe_processes("end")
        describe_shm("end")
        if args.keep is None:
            shutil.rmtree(directory, ignore_errors=True)
    return 0 if stops.first is None else 128 + stops.first


if __name__ == "__main__":
    sys.exit(main())
