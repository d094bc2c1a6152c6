"""Keep ROS 2 traffic on this machine unless the user asks for more, and leave nothing behind.

Fast DDS announces itself by multicast on every network interface by default. A mission
executive that students run on a laptop in a lab, and that CI runs hundreds of times, must not
spray discovery traffic over the network, so every entry point calls
:func:`apply_localhost_defaults` before ``rclpy.init``. A user who wants the simulator and the
executive on two machines sets ``ROS_AUTOMATIC_DISCOVERY_RANGE`` (and ``ROS_DOMAIN_ID``)
themselves; their values are never overwritten.

On loopback it also gives Fast DDS two shorter periods (``fastdds_profile.xml``, the default
profile unless the user names one with ``FASTDDS_DEFAULT_PROFILES_FILE`` or keeps one in the
working directory): participants announce themselves every 0.5 s and reliable writers ask their
readers what they lack every 0.1 s, instead of every 3 s: with 3 s, a start that missed the
other participant's first announcements, or a latched message, waits seconds for the next, and
every lockstep join waits for a heartbeat before the simulator has the acknowledgements it
answers a join after (docs/reference/evaluation.md, "Fast DDS's periods").
rmw_fastrtps still puts its loopback-only transports and every ROS QoS on top of the profile.

On loopback, rmw_fastrtps gives every participant (one per process) Fast DDS's shared-memory
transport: a segment in ``/dev/shm`` (``fastdds_<16 hex digits>`` and its lock file ``…_el``,
about 0.5 MB). The participant removes it when it is deleted; a process that ends without
deleting it leaves it there for good. Called for this process (no ``environment`` given),
:func:`apply_localhost_defaults` therefore also

* removes the segments of dead participants that this user left (:func:`remove_dead_segments`):
  what a process killed outright (SIGKILL) could not remove, the next process removes;
* has the process delete its participant on its way out (:func:`shut_ros_down_at_exit`, at
  exit): rclpy leaves that to the garbage collector, which at interpreter exit does not always
  get to it, so a run that ended cleanly could leave its segment behind.

One process keeps its participant on purpose: one whose peer was killed outright
(:func:`end_keeping_the_participant`). A peer killed while it wrote into this process's
segment can leave it so that Fast DDS crashes deleting the participant: a SIGSEGV in
``SharedMemChannelResource::release`` (from ``rcl_node_fini``), after the process has said
everything, in about one run in two hundred whose simulator is SIGKILLed beside a CPU hog
(``benchmarks/killed_simulator.py``). Its segment is left for the next process to remove, like
the killed peer's own.

(``FASTDDS_BUILTIN_TRANSPORTS=UDPv4`` would avoid the segments altogether, but rmw_fastrtps
replaces Fast DDS's builtin transports with its own, shared memory included, whenever discovery
is ``LOCALHOST``: see docs/reference/evaluation.md, "Leaks".)
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
from collections.abc import MutableMapping
from pathlib import Path
from typing import TYPE_CHECKING, NoReturn, Protocol, runtime_checkable

if TYPE_CHECKING:
    from rclpy.context import Context

__all__ = ["apply_localhost_defaults", "delete_participant", "end_keeping_the_participant",
           "remove_dead_segments", "shut_ros_down_at_exit", "uses_the_projects_profile"]

DISCOVERY_RANGE_VARIABLE = "ROS_AUTOMATIC_DISCOVERY_RANGE"
LOCALHOST = "LOCALHOST"

FAST_DDS_PROFILE = Path(__file__).with_name("fastdds_profile.xml")
PROFILE_VARIABLE = "FASTDDS_DEFAULT_PROFILES_FILE"
USER_PROFILE_VARIABLES = (PROFILE_VARIABLE, "FASTRTPS_DEFAULT_PROFILES_FILE")
USER_PROFILE_FILES = ("DEFAULT_FASTDDS_PROFILES.xml", "DEFAULT_FASTRTPS_PROFILES.xml")
"""Where a user keeps Fast DDS profiles of their own: the variables, or files Fast DDS reads from
the working directory."""
FAST_DDS_IMPLEMENTATIONS = ("rmw_fastrtps_cpp", "rmw_fastrtps_dynamic_cpp")

SHARED_MEMORY = Path("/dev/shm")
SEGMENT_LOCK = re.compile(r"^fastdds_[0-9a-f]{16}_el$")
"""A Fast DDS segment's lock file; the segment is the same name without ``_el``."""
SETTLED_S = 30.0
"""A lock file younger than this is left alone: its owner may not have locked it yet (it does
within microseconds of creating it)."""

_at_exit_registered = False


def apply_localhost_defaults(environment: MutableMapping[str, str] | None = None) -> None:
    """Default DDS discovery to localhost in ``environment`` (``os.environ`` when omitted).

    For this process (``environment`` omitted) also remove dead participants' shared-memory
    segments and have the process delete its own participant at exit.
    """
    target = os.environ if environment is None else environment
    if not target.get(DISCOVERY_RANGE_VARIABLE):
        target[DISCOVERY_RANGE_VARIABLE] = LOCALHOST
    if uses_the_projects_profile(target, working_directory=Path.cwd()):
        target[PROFILE_VARIABLE] = str(FAST_DDS_PROFILE)
    if environment is None:
        remove_dead_segments()
        _register_at_exit()


def uses_the_projects_profile(environment: MutableMapping[str, str], *,
                              working_directory: Path) -> bool:
    """Whether Fast DDS should read this project's profile: discovery stays on loopback, the
    middleware is Fast DDS (ROS 2's default), and the user keeps no profile of their own."""
    return (FAST_DDS_PROFILE.is_file()
            and environment.get(DISCOVERY_RANGE_VARIABLE) == LOCALHOST
            and environment.get("RMW_IMPLEMENTATION", FAST_DDS_IMPLEMENTATIONS[0])
            in FAST_DDS_IMPLEMENTATIONS
            and not any(environment.get(name) for name in USER_PROFILE_VARIABLES)
            and not any((working_directory / name).exists() for name in USER_PROFILE_FILES))


def remove_dead_segments(directory: Path = SHARED_MEMORY, *,
                         settled_s: float = SETTLED_S) -> list[str]:
    """Remove the Fast DDS shared-memory segments whose owner is dead; the names removed.

    A participant holds an exclusive ``flock`` on its segment's lock file for as long as it
    lives; the kernel releases it when the process ends, however it ends. A segment is removed
    only when that is provably over and the segment is this user's: the lock file and the
    segment belong to this user, the lock file is older than ``settled_s``, and this process
    gets the exclusive lock itself -- and holds it while both files are unlinked, so nobody can
    take the segment meanwhile. Anything else (a live owner, another user's files, an error) is
    left as it is.
    """
    try:
        names = os.listdir(directory)
    except OSError:
        return []
    removed = []
    for name in names:
        if SEGMENT_LOCK.match(name) and _remove_if_dead(directory, name, settled_s):
            removed.append(name[:-3])
    return removed


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


def shut_ros_down_at_exit() -> None:
    """Delete this process's DDS participant now, if rclpy made one.

    rclpy deletes a context's participant only once nothing uses the context any more, and
    leaves the rest to the garbage collector: ``Node.destroy_node`` does not destroy the node's
    waitables (an ``ActionClient`` keeps the node, and with it the context, alive), and objects
    in reference cycles or held by module globals are not always freed before the process ends.
    So this shuts rclpy's default context down (which destroys the nodes it tracks), collects
    the garbage, destroys every node still alive with its waitables, and destroys the context.

    Registered with :mod:`atexit` by :func:`apply_localhost_defaults`, so it runs on every way
    out the process controls (a return from ``main``, ``sys.exit``, an uncaught exception,
    Ctrl-C), before the interpreter puts the default signal handlers back: a late stop signal
    then finds the participant deleted already.
    """
    if "rclpy" not in sys.modules:
        return
    with contextlib.suppress(Exception):
        from rclpy.utilities import get_default_context

        delete_participant(get_default_context(), every_node=True)


def delete_participant(context: Context, *, every_node: bool = False) -> None:
    """Shut ``context`` down and delete its DDS participant now, not when the garbage goes.

    Shutting a context down destroys the publishers, subscriptions, services and timers of the
    nodes it tracks, but not their waitables: an action server or client holds its node, the
    node its context, and the participant stays in the domain with the action's endpoints, as
    a server nobody serves, until the garbage collector frees them (a test process that ran a
    dozen simulator tests in one domain had four such servers beside the live one). So this
    collects the garbage, destroys the context's nodes still alive (``every_node``: every
    node of the process) with their waitables, and destroys the context.
    """
    from rclpy.node import Node

    context.try_shutdown()
    gc.collect()
    for node in [item for item in gc.get_objects() if isinstance(item, Node)]:
        if not every_node and node.context is not context:
            continue
        for waitable in list(node.waitables):
            with contextlib.suppress(Exception):
                if isinstance(waitable, _Destroyable):
                    waitable.destroy()
        with contextlib.suppress(Exception):
            node.destroy_node()
    context.destroy()


def end_keeping_the_participant(exit_status: int) -> NoReturn:
    """End this process now with ``exit_status``, without deleting its DDS participant.

    For a process that has said everything (its report, its reply) and whose peer was killed
    outright: deleting the participant could then crash it (see the module's introduction).
    Standard output and error are flushed; no exit handler runs. The segment it leaves is
    removed by the next process (:func:`remove_dead_segments`).
    """
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(Exception):  # closed, or a reader that went away
            stream.flush()
    os._exit(exit_status)


@runtime_checkable
class _Destroyable(Protocol):
    """A waitable that holds resources of its own (an action client or server, an event
    handler): rclpy's ``Waitable`` itself declares no ``destroy``."""

    def destroy(self) -> None: ...


def _register_at_exit() -> None:
    global _at_exit_registered
    if not _at_exit_registered:
        atexit.register(shut_ros_down_at_exit)
        _at_exit_registered = True
