"""ROS bags in, grid_map MCAP out: real robot data for the mapper, read and written with rosbags.

A layer between :mod:`fogsim.viz` and :mod:`fogsim.run`: reading a bag makes a data-layer
recording, writing needs the pipeline's maps. No ROS install is needed (``rosbags`` is pure
Python).

* :mod:`fogsim.bags.topics` — :class:`BagOptions` (topics, tf frames, time tolerance) and
  :class:`BagError`;
* :mod:`fogsim.bags.tf` — :class:`TfTree`: ``/tf`` + ``/tf_static`` looked up at many stamps
  at once, interpolated in time;
* :mod:`fogsim.bags.urdf` — :class:`UrdfChain`: the camera in the base frame from joint
  states through the robot's URDF (pinocchio), for bags without it on tf;
* :mod:`fogsim.bags.images` — ``sensor_msgs/Image`` depth and ``CameraInfo`` decoded;
* :mod:`fogsim.bags.read` — :func:`bag_topics` (``--list``), :func:`read_bag_frames`,
  :func:`import_bag`: a ROS 1 or ROS 2 bag → the recording ``fogsim run --replay`` maps;
* :mod:`fogsim.bags.gridmap` — the FOG as ``grid_map_msgs/msg/GridMap`` (grid_map's axes,
  column-major data, start indices);
* :mod:`fogsim.bags.write` — :class:`McapMapWriter`: per frame a GridMap and the robot's pose
  into a rosbag2 bag in MCAP storage (``fogsim run --mcap``), written atomically.
"""
