"""What episodes must not leave behind: Fast DDS shared-memory segments in ``/dev/shm``.

Both processes of an episode, the executive and the simulator, delete their participant at exit
(``shut_ros_down_at_exit``) and remove the segments of dead participants when they start
(``remove_dead_segments``). Each has its own copy (they share no code), so every check here runs
on both.
"""

from __future__ import annotations

import fcntl
import os
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import pytest

from bt_servicesim.ros import environment as executive_environment
from servicesim_sim.process import environment as simulator_environment

SWEEPS: dict[str, Callable[..., list[str]]] = {
    "executive": executive_environment.remove_dead_segments,
    "simulator": simulator_environment.remove_dead_segments,
}

# The segments whose lock file this process holds open (one per participant), for the scripts
# below: their names, space-separated.
OWN_SEGMENTS = r"""
def own_segments():
    import os, re
    names = []
    for descriptor in os.listdir("/proc/self/fd"):
        try:
            target = os.readlink(f"/proc/self/fd/{descriptor}")
        except OSError:
            continue
        found = re.search(r"/dev/shm/(fastdds_[0-9a-f]{16})_el$", target)
        if found:
            names.append(found.group(1))
    return " ".join(names)
"""

# A participant whose node is kept alive to the very end by a daemon thread (as entities caught
# in cycles through C++ callbacks are): rclpy never deletes it, and without the exit hook its
# segment stays in /dev/shm.
KEPT_ALIVE = OWN_SEGMENTS + r"""
import sys, threading, time
if sys.argv[1] == "executive":
    from bt_servicesim.ros.environment import apply_localhost_defaults as defaults
else:
    from servicesim_sim.process.environment import apply_environment_defaults as defaults
defaults()
import rclpy
from rclpy.action import ActionClient
from rclpy.node import Node
from nav2_msgs.action import NavigateToPose
rclpy.init()
node = Node("kept_alive")
client = ActionClient(node, NavigateToPose, "/kept_alive")  # destroy_node() leaves it
print(own_segments(), flush=True)
node.destroy_node()
rclpy.try_shutdown()
threading.Thread(target=lambda held=(node, client): time.sleep(1000), daemon=True).start()
"""


@pytest.mark.parametrize("program", ["executive", "simulator"])
def test_a_participant_kept_alive_to_the_end_is_deleted_at_exit(program: str) -> None:
    result = subprocess.run([sys.executable, "-c", KEPT_ALIVE, program], capture_output=True,
                            text=True, timeout=60, env=dict(os.environ))
    assert result.returncode == 0, result.stderr
    segments = result.stdout.split()
    assert len(segments) == 1, "one participant, one segment of its own"
    segment = segments[0]
    assert not (Path("/dev/shm") / segment).exists(), "the segment went with the process"
    assert not (Path("/dev/shm") / f"{segment}_el").exists()


# A process that ends on purpose without deleting its participant (its peer was killed): its
# output so far is flushed, no exit handler runs, and its segment is left for the next process.
KEPT_ON_PURPOSE = OWN_SEGMENTS + r"""
import atexit
from bt_servicesim.ros.environment import apply_localhost_defaults, end_keeping_the_participant
apply_localhost_defaults()
import rclpy
from rclpy.node import Node
rclpy.init()
node = Node("kept_on_purpose")
print(own_segments())
atexit.register(print, "an exit handler ran")
print("said", end="")
end_keeping_the_participant(3)
"""


def test_a_participant_kept_on_purpose_is_left_for_the_next_process_to_remove() -> None:
    result = subprocess.run([sys.executable, "-c", KEPT_ON_PURPOSE], capture_output=True,
                            text=True, timeout=60, env=dict(os.environ))
    assert result.returncode == 3, result.stderr
    printed, said = result.stdout.split("\n")
    segments = printed.split()
    assert said == "said", "what it printed is flushed, and no exit handler ran"
    assert len(segments) == 1, "one participant, one segment of its own"
    segment = Path("/dev/shm") / segments[0]
    lock = segment.with_name(f"{segment.name}_el")
    try:
        assert segment.exists(), "the participant was not deleted"
        descriptor = os.open(lock, os.O_RDONLY)
        try:  # what remove_dead_segments asks of a segment it removes, its age aside
            fcntl.flock(descriptor, fcntl.LOCK_EX | fcntl.LOCK_NB)
        finally:
            os.close(descriptor)
    finally:
        segment.unlink(missing_ok=True)
        lock.unlink(missing_ok=True)


def make_segment(directory: Path, number: int, *, age_s: float) -> Path:
    """A segment and its lock file, as Fast DDS makes them; returns the lock file."""
    name = f"fastdds_{number:016x}"
    (directory / name).write_bytes(b"\0" * 64)
    lock = directory / f"{name}_el"
    lock.touch()
    then = time.time() - age_s
    for path in (directory / name, lock):
        os.utime(path, (then, then))
    return lock


@pytest.mark.parametrize("program", list(SWEEPS))
def test_only_segments_provably_dead_and_ours_are_removed(tmp_path: Path, program: str) -> None:
    dead = make_segment(tmp_path, 1, age_s=600.0)
    live = make_segment(tmp_path, 2, age_s=600.0)
    young = make_segment(tmp_path, 3, age_s=0.0)
    lock_alone = make_segment(tmp_path, 4, age_s=600.0)
    (tmp_path / lock_alone.name[:-3]).unlink()
    others = [tmp_path / "fastdds_port7411", tmp_path / "fastdds_port7411_el",
              tmp_path / "fastdds_xyz_el", tmp_path / "sem.fastdds_port7411_mutex"]
    for path in others:
        path.touch()
        os.utime(path, (0, 0))
    foreign = make_segment(tmp_path, 5, age_s=600.0) if os.getuid() == 0 else None
    if foreign is not None:  # another user's: never ours to remove
        for path in (foreign, tmp_path / foreign.name[:-3]):
            os.chown(path, 12345, 12345)
    with live.open("rb") as owner:
        fcntl.flock(owner, fcntl.LOCK_EX | fcntl.LOCK_NB)  # a live participant holds its lock
        removed = SWEEPS[program](tmp_path)
    assert sorted(removed) == sorted([dead.name[:-3], lock_alone.name[:-3]])
    assert not dead.exists() and not (tmp_path / dead.name[:-3]).exists()
    assert not lock_alone.exists()
    for kept in (live, young):
        assert kept.exists() and (tmp_path / kept.name[:-3]).exists()
    assert all(path.exists() for path in others)
    if foreign is not None:
        assert foreign.exists() and (tmp_path / foreign.name[:-3]).exists()


def test_the_two_copies_agree() -> None:
    """The executive and the simulator share no code; what they judge dead must not drift."""
    for name in ("SEGMENT_LOCK", "SETTLED_S", "SHARED_MEMORY"):
        assert getattr(executive_environment, name) == getattr(simulator_environment, name)


def test_only_this_process_environment_is_swept(tmp_path: Path,
                                                monkeypatch: pytest.MonkeyPatch) -> None:
    """Defaults for a child's environment (the evaluation's episodes) touch nothing else."""
    swept: list[bool] = []
    monkeypatch.setattr(executive_environment, "remove_dead_segments",
                        lambda *args, **kwargs: swept.append(True) or [])
    monkeypatch.chdir(tmp_path)
    child: dict[str, str] = {}
    executive_environment.apply_localhost_defaults(child)
    assert child == {"ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST",
                     "FASTDDS_DEFAULT_PROFILES_FILE": str(executive_environment.FAST_DDS_PROFILE)}
    assert not swept
    executive_environment.apply_localhost_defaults()
    assert swept == [True]
