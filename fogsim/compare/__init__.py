"""The benchmark of the field: the FOG beside the height maps users pick instead (issue 16).

The same frames go into every map (:mod:`fogsim.compare.replay`), every map is scored with the
same truth by :mod:`fogsim.eval`, and :mod:`fogsim.compare.table` writes the mean and worst of
every figure over the runs; :func:`fogsim.compare.command.run_compare` is what ``fogsim
compare`` does.
"""
