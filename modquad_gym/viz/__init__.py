"""Drawing: :mod:`.raster` renders a structure's top view with numpy alone (the env's
``rgb_array`` frames); :mod:`.drawing` makes matplotlib figures (structure, torque projection,
rotor inputs). Drawing depends only on the layers it draws (geometry, oracle) and may be used by
any layer above them. Importing this package imports neither."""
