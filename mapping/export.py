"""Map products on disk: ``com.npz`` and an occupancy grid in ROS map_server format."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import yaml

from slam.atomic import write_bytes_atomic, write_text_atomic

#: map_saver's classification of an occupancy probability: occupied at or above, free at or below.
OCCUPIED_THRESH = 0.65
FREE_THRESH = 0.25

#: The trinary grey levels map_saver writes, and the thresholds its map.yaml gives map_server to
#: read them back: occupancy (255 - level) / 255 above 0.65 is occupied (0 -> 1.0), below 0.196
#: is free (254 -> 0.004), in between unknown (205 -> 0.196078..., just above 0.196).
FREE_LEVEL, OCCUPIED_LEVEL, UNKNOWN_LEVEL = 254, 0, 205
MAP_SERVER_OCCUPIED_THRESH = 0.65
MAP_SERVER_FREE_THRESH = 0.196


def save_com(path: str | Path, com) -> None:
    """Write ``com.npz``: ``prob`` (Λ), ``prob_occ`` (Λo), ``prob_free`` (Λf), their variances
    ``var``, ``var_occ``, ``var_free`` (all (h, w), row 0 at the bottom), ``origin`` (x, y of
    the centre of cell (0, 0), m) and ``resolution`` (m)."""
    buf = io.BytesIO()
    np.savez_compressed(buf, prob=com.prob(), prob_occ=com.prob_occ(), prob_free=com.prob_free(),
                        var=com.var(), var_occ=com.var_occ(), var_free=com.var_free(),
                        origin=np.asarray(com.origin, float), resolution=np.float64(com.resolution))
    write_bytes_atomic(Path(path), buf.getvalue())


def write_ros_map(pgm_path: str | Path, prob: np.ndarray, origin: np.ndarray, resolution: float,
                  occupied_thresh: float = OCCUPIED_THRESH, free_thresh: float = FREE_THRESH) -> Path:
    """Write ``prob`` (h, w, row 0 at the bottom) as a trinary ROS map, as map_saver does:
    ``map.pgm`` (P5; 0 where ``prob >= occupied_thresh``, 254 where ``prob <= free_thresh``, 205
    unknown elsewhere and where ``prob`` is NaN) and ``map.yaml`` beside it, whose thresholds
    (0.65, 0.196: map_saver's) read those levels back as occupied, free and unknown. ``origin``
    is the centre of cell (0, 0); the YAML holds the lower-left corner, as map_server wants.
    Returns the YAML path."""
    prob = np.asarray(prob, float)
    if prob.ndim != 2 or prob.size == 0:
        raise ValueError(f"write_ros_map: need a non-empty (h, w) map, got {prob.shape}")
    if not 0 <= free_thresh < occupied_thresh <= 1:
        raise ValueError(f"write_ros_map: need 0 <= free_thresh < occupied_thresh <= 1, got "
                         f"{free_thresh}, {occupied_thresh}")
    pgm_path = Path(pgm_path)
    image = np.full(prob.shape, UNKNOWN_LEVEL, np.uint8)
    image[prob >= occupied_thresh] = OCCUPIED_LEVEL
    image[prob <= free_thresh] = FREE_LEVEL
    image = image[::-1]                                   # PGM rows run top to bottom
    h, w = image.shape
    write_bytes_atomic(pgm_path, f"P5\n{w} {h}\n255\n".encode() + image.tobytes())
    corner = np.asarray(origin, float) - 0.5 * resolution
    meta = {"image": pgm_path.name, "mode": "trinary", "resolution": float(resolution),
            "origin": [float(corner[0]), float(corner[1]), 0.0], "negate": 0,
            "occupied_thresh": MAP_SERVER_OCCUPIED_THRESH, "free_thresh": MAP_SERVER_FREE_THRESH}
    yaml_path = pgm_path.with_suffix(".yaml")
    write_text_atomic(yaml_path, yaml.safe_dump(meta, sort_keys=False))
    return yaml_path
