"""The world a simulator plays: world files, their maps and target areas, and the office.

Design intent: a world is an immutable value (:class:`~servicesim_sim.world.files.World`)
loaded and checked once, which the model, navigation and the people share; the default
office is authored as data (:mod:`servicesim_sim.world.office`) and its files generated from
it. Nothing here moves or knows of ROS (an import contract checks it).
"""
