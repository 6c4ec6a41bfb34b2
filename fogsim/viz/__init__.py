"""Layer 8 — pictures: the paper's figures, the difference picture and the run video.

Modules: ``style`` (backend, colours, extents, saving), ``pictures`` (Fig. 7, 3 and 5, the
video, :func:`~fogsim.viz.pictures.write_pictures`) and ``difference`` (``difference.png``).
"""
