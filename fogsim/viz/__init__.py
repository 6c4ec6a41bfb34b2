"""Layer 8 — pictures: the paper's figures, the difference picture and the run video.

Modules: ``style`` (backend, colours, extents, saving), ``pictures`` (Fig. 7, 3 and 5,
:func:`~fogsim.viz.pictures.write_pictures`), ``difference`` (``difference.png``), ``video``
(``run.mp4``) and ``rerun_log`` (the Rerun recording).
"""
