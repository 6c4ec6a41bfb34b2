"""End to end: `FloorObstacleMapper` passes `MapperParams.edge_band_m` to the FOG update."""

import numpy as np

from mapper import CellType, FloorObstacleMapper, MapperParams


def test_the_mapper_takes_the_edge_band_from_its_params():
    """A ground patch at 0 over x 0.6..1.0 (cells 65..74) and a 61 mm tread over x 0.8..1.0
    (cells 70..74), its riser on the boundary x = 0.8. Band 0 (the paper): cells 69 and 70 are
    floors at 0 and 0.061; band 0.02: the tread's rim cell 70 (beside a floor more than the band
    below it) is unknown, the ground cell 69 at its foot and cells 68 and 71 floors."""
    sensor = np.array([0.0, 0.0, 0.55])
    fogs = {}
    for band in (0.0, 0.02):
        rng = np.random.default_rng(3)
        m = FloorObstacleMapper(MapperParams(edge_band_m=band))
        for _ in range(10):
            n = 800
            xy = np.column_stack([rng.uniform(0.6, 1.0, n), rng.uniform(-0.2, 0.2, n)])
            h = np.where(xy[:, 0] >= 0.8, 0.061, 0.0)
            points = np.column_stack([xy, h + rng.uniform(-0.003, 0.003, n)])
            m.update(points, h, sensor)
        fogs[band] = m.fog()
    (types0, heights0), (types1, _) = fogs[0.0], fogs[0.02]
    row = 50  # y 0..0.04
    assert types0[68:72, row].tolist() == [CellType.FLOOR] * 4
    assert abs(heights0[69, row]) < 0.005 and abs(heights0[70, row] - 0.061) < 0.005
    assert types1[68:72, row].tolist() == [
        CellType.FLOOR,
        CellType.FLOOR,
        CellType.UNKNOWN,
        CellType.FLOOR,
    ]
