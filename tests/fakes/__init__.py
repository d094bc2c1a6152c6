"""Stand-ins that several test modules share, one module per thing faked, so that the tests of
different packages script the same fakes:

- :mod:`~tests.fakes.spinning`: a bounded ``spin_until``, ``wait_for_subscription``,
  ``clock_message``, ``unique_name``;
- :mod:`~tests.fakes.graphs`: graphs a test spins from its own thread (``ExecutiveGraph``,
  ``SimTimeGraph``, ``SensorWorld``);
- :mod:`~tests.fakes.servers`, :mod:`~tests.fakes.referee`, :mod:`~tests.fakes.navigator`,
  :mod:`~tests.fakes.simulator`: fake servers, scripted and logging what they saw;
- :mod:`~tests.fakes.leaves`: a leaf's ports wired (``ready``, ``wire``);
- :mod:`~tests.fakes.maps`: maps and costmaps; :mod:`~tests.fakes.guest`: the guest's names,
  RFID readings along a drive, approach goals checked;
- :mod:`~tests.fakes.recorded_run`: the errand tree run to its end with a tree log;
- :mod:`~tests.fakes.commands`: ``python -m`` with its output captured.

The fixtures built on these (``ros_context``, ``sim_clock``, ``world``, the blackboard cleaned
round every test) are in ``conftest.py``.
"""
