"""The simulator's process around ROS: traffic on this machine, and nothing left behind.

The simulator shares no code with the executive (they share only ROS interfaces), so this is
the simulator's own copy of what the executive's ``bt_servicesim/ros/environment.py`` does:

* discovery stays on loopback unless the user set ``ROS_AUTOMATIC_DISCOVERY_RANGE``;
* on loopback with Fast DDS, and unless a profile was named (``FASTDDS_DEFAULT_PROFILES_FILE``,
  also when the executive that started the simulator named its own) or lies in the working
  directory, Fast DDS reads ``fastdds_profile.xml``: participants announce themselves every
  0.5 s and reliable writers send heartbeats every 0.1 s, instead of every 3 s, so that a client
  starting beside the simulator finds it, and the latched messages it missed, without waiting
  3 s, and a join is answered as soon as the client's readers have acknowledged what they hold
  (they acknowledge when a heartbeat asks);
* Fast DDS publishes synchronously (``RMW_FASTRTPS_PUBLICATION_MODE=SYNCHRONOUS``, whatever the
  user set): lockstep counts every message the simulator publishes, and a writer keeps only
  its last few (:data:`~servicesim_sim.ros.publishing.REPAIR_DEPTH`). Published asynchronously,
  a message waits in that history for Fast DDS's own thread to send it, and later ones
  published on the topic can replace it unsent: a client then never gets (say) the referee's
  state of one period, and lockstep waits for it 10 s before it drops the client (4 of 14 runs
  with the user's setting ``ASYNCHRONOUS`` and one-deep latched writers, at the join or
  later). Sent within ``publish``, a message is on its way before the next replaces it, and
  one lost on the way is still held to be sent again;
* the Fast DDS shared-memory segments that dead participants of this user left in ``/dev/shm``
  (``fastdds_<16 hex digits>`` and its lock file ``…_el``) are removed: a participant holds an
  exclusive ``flock`` on its lock file while it lives, so a segment whose lock this process can
  take (and holds while it unlinks both files), whose files are this user's and older than a
  few seconds, has no owner left;
* at exit the process deletes its own participant: rclpy leaves that to the garbage collector,
  which does not always get to it before the process ends (the segment then stays for good).
"""

from __future__ import annotations

import atexit
import contextlib
import fcntl
import gc
import os
import re
import stat
import sys
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Protocol, runtime_checkable

__all__ = ["apply_environment_defaults", "reads_the_simulators_profile", "remove_dead_segments",
           "shut_ros_down_at_exit"]

FAST_DDS_PROFILE = Path(__file__).with_name("fastdds_profile.xml")
USER_PROFILE_VARIABLES = ("FASTDDS_DEFAULT_PROFILES_FILE", "FASTRTPS_DEFAULT_PROFILES_FILE")
USER_PROFILE_FILES = ("DEFAULT_FASTDDS_PROFILES.xml", "DEFAULT_FASTRTPS_PROFILES.xml")
FAST_DDS_IMPLEMENTATIONS = ("rmw_fastrtps_cpp", "rmw_fastrtps_dynamic_cpp")
PUBLICATION_MODE_VARIABLE = "RMW_FASTRTPS_PUBLICATION_MODE"

SHARED_MEMORY = Path("/dev/shm")
SEGMENT_LOCK = re.compile(r"^fastdds_[0-9a-f]{16}_el$")
SETTLED_S = 30.0  # a younger lock file may not be locked by its owner yet

_at_exit_registered = False


def apply_environment_defaults() -> None:
    """Before ``rclpy.init``: loopback discovery by default, synchronous publication, dead
    segments removed, and the participant deleted at exit."""
    if not os.environ.get("ROS_AUTOMATIC_DISCOVERY_RANGE"):
        os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    os.environ[PUBLICATION_MODE_VARIABLE] = "SYNCHRONOUS"  # see the module docstring
    if reads_the_simulators_profile(os.environ, working_directory=Path.cwd()):
        os.environ[USER_PROFILE_VARIABLES[0]] = str(FAST_DDS_PROFILE)
    remove_dead_segments()
    global _at_exit_registered
    if not _at_exit_registered:
        atexit.register(shut_ros_down_at_exit)
        _at_exit_registered = True


def reads_the_simulators_profile(environment: Mapping[str, str], *,
                                 working_directory: Path) -> bool:
    """Whether Fast DDS should read ``fastdds_profile.xml``: loopback discovery, Fast DDS (ROS
    2's default), and no profile named or kept in the working directory."""
    return (FAST_DDS_PROFILE.is_file()
            and environment.get("ROS_AUTOMATIC_DISCOVERY_RANGE") == "LOCALHOST"
            and environment.get("RMW_IMPLEMENTATION", FAST_DDS_IMPLEMENTATIONS[0])
            in FAST_DDS_IMPLEMENTATIONS
            and not any(environment.get(name) for name in USER_PROFILE_VARIABLES)
            and not any((working_directory / name).exists() for name in USER_PROFILE_FILES))


def remove_dead_segments(directory: Path = SHARED_MEMORY, *,
                         settled_s: float = SETTLED_S) -> list[str]:
    """Remove the shared-memory segments of this user's dead participants; the names removed."""
    try:
        names = os.listdir(directory)
    except OSError:
        return []
    return [name[:-3] for name in names
            if SEGMENT_LOCK.match(name) and _remove_if_dead(directory, name, settled_s)]


def _remove_if_dead(directory: Path, lock_name: str, settled_s: float) -> bool:
    lock_path, segment_path = directory / lock_name, directory / lock_name[:-3]
    try:
        descriptor = os.open(lock_path, os.O_RDONLY | os.O_NOFOLLOW | os.O_CLOEXEC)
    except OSError:
        return False
    try:
        lock = os.fstat(descriptor)
        if (lock.st_uid != os.getuid() or not stat.S_ISREG(lock.st_mode)
                or time.time() - lock.st_mtime < settled_s):
            return False
        with contextlib.suppress(FileNotFoundError):
            segment = os.lstat(segment_path)
            if segment.st_uid != os.getuid() or not stat.S_ISREG(segment.st_mode):
                return False
        try:
            fcntl.flock(descriptor, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:  # held: its owner is alive
            return False
        with contextlib.suppress(FileNotFoundError):
            os.unlink(segment_path)
        with contextlib.suppress(FileNotFoundError):
            if os.lstat(lock_path).st_ino == lock.st_ino:  # still the file that was locked
                os.unlink(lock_path)
        return True
    except OSError:
        return False
    finally:
        os.close(descriptor)  # releases the lock


@runtime_checkable
class _Destroyable(Protocol):
    """A waitable that holds resources of its own (an action server, an event handler):
    rclpy's ``Waitable`` itself declares no ``destroy``."""

    def destroy(self) -> None: ...


def shut_ros_down_at_exit() -> None:
    """Delete this process's DDS participant: shut rclpy's default context down, collect the
    garbage, destroy every node still alive with its waitables (``destroy_node`` leaves those,
    and an action server keeps the context in use), then destroy the context."""
    if "rclpy" not in sys.modules:
        return
    with contextlib.suppress(Exception):
        from rclpy.node import Node
        from rclpy.utilities import get_default_context

        context = get_default_context()
        context.try_shutdown()
        gc.collect()
        for node in [item for item in gc.get_objects() if isinstance(item, Node)]:
            for waitable in list(node.waitables):
                with contextlib.suppress(Exception):
                    if isinstance(waitable, _Destroyable):
                        waitable.destroy()
            with contextlib.suppress(Exception):
                node.destroy_node()
        context.destroy()
