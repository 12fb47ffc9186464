"""aion_cli.sim: realistic synthetic robot logs with ground truth (``aion simulate``).

One module per job, all plain numpy arrays:

- ``environment`` / ``office``: the walkable place graph (the paper's office, or a real spark_dsg
  scene graph), rooms, building, walls, mesh, named roles.
- ``schedule``: daily and weekly routines → planned moves per agent.
- ``agents``: moves → positions walked along place-graph paths at the sensor rate.
- ``robot``: patrol tours, odometry drift, loop closures, sensor visibility.
- ``sensing``: what the tracker publishes (visible, noisy, in base_link or map, track ids).
- ``graphstream``: the Hydra-like scene-graph stream (growth, drift, moves, merges, removals) and
  its spark_dsg payloads.
- ``messages`` / ``tfcodec`` / ``writer``: ROS messages and the time-ordered log.
- ``ground_truth``: true flows per place, window and direction bin, events, coverage.
- ``scenario``: configuration and the end-to-end run (:func:`scenario.simulate`).

This package never imports click or rich; ``aion_cli.cli.simulate`` is its command line.
"""
