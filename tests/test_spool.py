"""fogsim.data.spool: arrays on anonymous temporary files."""

import numpy as np
import pytest

from fogsim.data.spool import spooled_array
from fogsim.errors import OutputError


def test_a_spooled_array_holds_its_values_and_leaves_no_file(tmp_path):
    array = spooled_array((3, 4, 5), np.float32, tmp_path)
    assert array.shape == (3, 4, 5) and array.dtype == np.float32
    assert not array.any()  # zero-filled
    array[1] = np.arange(20, dtype=np.float32).reshape(4, 5)
    assert float(array[1, 3, 4]) == 19.0 and float(array[2].sum()) == 0.0
    assert not list(tmp_path.iterdir())  # unlinked at creation: nothing to clean up


def test_a_missing_folder_is_an_output_error_naming_it(tmp_path):
    missing = tmp_path / "nowhere"
    with pytest.raises(OutputError, match=r"cannot spool 0\.0 MB of images to .*nowhere"):
        spooled_array((2, 2), np.float32, missing)


def test_an_empty_shape_is_refused():
    with pytest.raises(ValueError, match=r"every side >= 1, got shape \(0, 4\)"):
        spooled_array((0, 4), np.float32)
