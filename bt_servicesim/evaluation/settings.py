"""What an evaluation is asked to do, and the limits it keeps to.

:class:`EvaluationSettings` is the evaluate command's checked input; everything the batch, the
statistics and the report need comes from it. :func:`load_warning` says when the requested
load asks for more cores than the machine has: in lockstep (the simulator's default) that makes
the evaluation slower, never different; a free-running backend would lag behind.
"""

from __future__ import annotations

import hashlib
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

from bt_servicesim.evaluation.reproducibility import Reproducibility
from bt_servicesim.evaluation.throughput import Throughput
from bt_servicesim.ros.domain import DOMAINS
from bt_servicesim.tree.files import DEFAULT_TREE, nav_params_for

#: Episodes run flat out by default: every episode runs in lockstep with our simulator, which
#: waits for each tick, so a busy machine makes an episode slower, never different.
DEFAULT_SPEED = 0.0


MAX_JOBS = len(DOMAINS) - 1
"""Episodes at once: each run claims a ROS domain of its own (:mod:`bt_servicesim.ros.domain`),
and one of them may be the user's, which no run claims."""


MAX_TIME_LIMIT_S = 1e6
"""The longest mission time limit in sim seconds, as ``python -m bt_servicesim.run`` allows."""


MAX_EPISODE_TIMEOUT_S = 1e6
"""The longest wall-time limit of an episode, in wall seconds (eleven days): longer is a typo."""


STOP_GRACE_S = 10.0  # wall seconds a stopped episode gets to write its report


EPISODE_CPU_S_PER_SIM_S = 0.048
"""CPU seconds an episode spends per sim second, simulator and executive together, in lockstep:
an upper figure of what ``benchmarks/sim_rtf.py --speed 0 --timing both`` prints per process
(docs/reference/performance.md), for the warning that a ``--speed`` asks for more cores than
the machine has."""


EPISODE_NAME = "episode.json"  # the episode's row, kept for --resume


EVALUATION_TRAJECTORIES = ("failed", "never")
"""When an evaluation's episodes draw ``trajectory.png`` (``evaluate --trajectory``)."""


INTERRUPTED = "evaluation interrupted"
"""The failure of an episode the evaluation stopped because it was stopped itself."""


PENALTY_KEYS = ("failed_pickup", "failed_dropoff", "too_fast", "drifts", "contact",
                "approximation")


@dataclass(frozen=True)
class EvaluationSettings:
    episodes: int
    scenarios: tuple[str, ...]
    executives: tuple[str, ...]
    jobs: int
    seed: int
    out: Path
    speed: float
    episode_timeout_s: float
    time_limit_s: float
    docs: Path | None
    command_line: str
    resume: bool = False
    cold: bool = False
    """Every episode a ``run`` process of its own, as before warm pairs (for comparisons)."""
    reproducibility: Reproducibility | None = None
    """The figures of ``benchmarks/reproducibility.py --json`` that results.md states."""
    throughput: Throughput | None = None
    """The figures of ``benchmarks/throughput.py --json`` that results.md states."""
    tree: Path = DEFAULT_TREE
    """The mission tree the ``bt`` executive plays (an absolute path, checked to load)."""
    trees: Mapping[str, Path] = field(default_factory=dict)
    """The tree each ``bt:NAME`` executive plays (``--executive bt:FILE``), by its name."""
    nav_params: str | None = None
    """``--nav-params`` as given: a file every episode's simulator is given, whatever the
    executive (absolute, checked), or ``servicebot``; None: each executive's default
    (:func:`~bt_servicesim.tree.files.nav_params_for`)."""
    trajectory: str = "failed"
    """When an episode draws its ``trajectory.png``: ``failed`` (a mission that did not
    complete) or ``never`` (an evaluation whose figures are all that is wanted)."""

    @property
    def own_tree(self) -> bool:
        """Whether ``bt`` plays a tree other than the shipped one."""
        return self.tree.resolve() != DEFAULT_TREE.resolve()

    def tree_of(self, executive: str) -> Path | None:
        """The tree file a run of ``executive`` must be given (``--tree``): that of a
        ``bt:NAME``, or ``--tree``'s for ``bt``; None for the shipped tree or no tree."""
        if executive in self.trees:
            return self.trees[executive]
        return self.tree if executive == "bt" and self.own_tree else None

    def played_tree(self, executive: str) -> Path | None:
        """The tree file an episode of ``executive`` plays: its own, or the shipped one for
        ``bt``; None for an executive without a tree (the baseline)."""
        own = self.tree_of(executive)
        if own is not None:
            return own
        return DEFAULT_TREE if executive_kind(executive) == "bt" else None

    def nav_params_of(self, executive: str) -> Path | None:
        """The navigation parameters file an episode of ``executive`` plays with; None: the
        servicebot's configuration, the simulator's default."""
        return nav_params_for(executive_kind(executive), self.nav_params)


def executive_kind(executive: str) -> str:
    """What runs an executive of the evaluation: ``bt:NAME`` is a ``bt`` with its own tree."""
    return executive.split(":", 1)[0]


def tree_digest(tree: Path) -> str:
    """A tree file's SHA-256 (or a navigation parameters file's): what an episode kept for
    ``--resume`` must have played, and what results.md and summary.json name."""
    try:
        return hashlib.sha256(tree.read_bytes()).hexdigest()
    except OSError:
        return "unreadable"


def load_warning(*, jobs: int, speed: float, cores: int) -> str | None:
    """Why these settings ask for more cores than the machine has, or None.

    An episode at speed X needs about X times :data:`EPISODE_CPU_S_PER_SIM_S` of CPU per wall
    second (simulator and executive together); asked for more than the machine has, the
    episodes run slower than ``--speed`` says. Every episode runs in lockstep with our
    simulator, so that changes no result. At speed 0 (flat out, the default) nothing is asked
    for but the cores there are, and more episodes than cores only share them, so there is
    nothing to warn about.
    """
    if speed <= 0.0:
        return None
    needed = jobs * speed * EPISODE_CPU_S_PER_SIM_S
    if needed <= cores:
        return None
    return (f"--jobs {jobs} at --speed {speed:g} needs about {needed:.1f} cores; this machine "
            f"has {cores}: the episodes will run slower than --speed asks (in lockstep that "
            f"changes no result; fewer --jobs or a lower --speed avoids it)")
