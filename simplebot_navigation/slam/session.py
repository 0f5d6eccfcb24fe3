"""A SLAM session on disk (slam_toolbox's serialize_map / deserialize_map): the pose graph and every node's scan,
so that mapping can go on later, or a robot can localize on it.

One ``.npz`` file (numpy's zip of arrays, read without pickle). Anything wrong with it (not a zip, truncated, a
missing or malformed array, another version) raises ValueError with one line naming the file and the problem.
"""

from __future__ import annotations

import zipfile
from pathlib import Path

import numpy as np

from simplebot_navigation.slam.mapper import MAX_NODES, Mapper
from simplebot_navigation.slam.params import SlamParams
from simplebot_navigation.slam.pose_graph import PoseGraph
from simplebot_navigation.slam.scan_points import MAX_BEAMS, ScanPoints

FORMAT = "simplebot_navigation slam session"
VERSION = 1
SUFFIX = ".posegraph.npz"


def session_path(name: str | Path) -> Path:
    """The file of a session named ``name`` (slam_toolbox's filename, without suffix)."""
    name = str(name)
    return Path(name if name.endswith(SUFFIX) else name + SUFFIX)


def save(mapper: Mapper, name: str | Path) -> Path:
    """Write the session; OSError when the file cannot be written (the caller names it)."""
    if not mapper.scans:
        raise ValueError("the session has no node yet: nothing to save")
    path = session_path(name)
    counts = np.array([len(s) for s in mapper.scans], dtype=np.int64)
    arrays = {f"graph_{k}": v for k, v in mapper.graph.to_arrays().items()}
    arrays.update(
        format=np.array(FORMAT), version=np.array(VERSION), resolution=np.array(mapper.params.resolution),
        odometry=np.array(mapper.odometry, dtype=np.float64), travel=np.array(mapper.travel, dtype=np.float64),
        beam_counts=counts, origins=np.concatenate([s.origins for s in mapper.scans]),
        ends=np.concatenate([s.ends for s in mapper.scans]), hits=np.concatenate([s.hits for s in mapper.scans]))
    tmp = path.with_name(path.name + ".tmp")
    with open(tmp, "wb") as f:
        np.savez_compressed(f, **arrays)
    tmp.replace(path)
    return path


def load(name: str | Path, params: SlamParams) -> Mapper:
    """A mapper holding the saved session, its map rendered at the saved resolution; ValueError naming the file."""
    path = session_path(name)
    try:
        with np.load(path, allow_pickle=False) as data:
            arrays = {k: data[k] for k in data.files}
    except FileNotFoundError:
        raise ValueError(f"{path}: no such file") from None
    except (OSError, ValueError, EOFError, zipfile.BadZipFile) as err:
        reason = "it holds pickled data" if "pickle" in str(err) else str(err)
        raise ValueError(f"{path}: not a readable session file ({reason})") from None
    try:
        return _mapper(arrays, params)
    except (KeyError, IndexError, TypeError) as err:
        raise ValueError(f"{path}: malformed session ({type(err).__name__}: {err})") from None
    except ValueError as err:
        raise ValueError(f"{path}: {err}") from None


def _mapper(arrays: dict, params: SlamParams) -> Mapper:
    if str(arrays["format"]) != FORMAT or int(arrays["version"]) != VERSION:
        raise ValueError(f"not a version {VERSION} session (format {str(arrays['format'])!r}, "
                         f"version {arrays['version']})")
    resolution = float(arrays["resolution"])
    if resolution != params.resolution:
        raise ValueError(f"saved at resolution {resolution:g} m, the node's resolution is {params.resolution:g} m")
    graph = PoseGraph.from_arrays({k[6:]: v for k, v in arrays.items() if k.startswith("graph_")})
    counts = np.asarray(arrays["beam_counts"])
    n = len(graph)
    if counts.shape != (n,) or counts.dtype.kind not in "iu" or (counts < 0).any() or (counts > MAX_BEAMS).any():
        raise ValueError(f"beam_counts: expected {n} counts of 0..{MAX_BEAMS}")
    if not 1 <= n <= MAX_NODES:
        raise ValueError(f"{n} nodes: a session holds 1 to {MAX_NODES}")
    odometry, travel = np.asarray(arrays["odometry"], dtype=np.float64), np.asarray(arrays["travel"], np.float64)
    if odometry.shape != (n, 3) or travel.shape != (n,) or not (np.isfinite(odometry).all()
                                                                 and np.isfinite(travel).all()):
        raise ValueError(f"odometry / travel: expected {n} finite poses and distances")
    total = int(counts.sum())
    origins, ends, hits = arrays["origins"], arrays["ends"], arrays["hits"]
    if origins.shape != (total, 2) or ends.shape != (total, 2) or hits.shape != (total,) or hits.dtype != bool:
        raise ValueError(f"origins / ends / hits: expected {total} beams")
    bounds = np.concatenate(([0], np.cumsum(counts)))
    mapper = Mapper(params)
    mapper.graph = graph
    mapper.scans = [ScanPoints(np.array(origins[a:b], np.float64), np.array(ends[a:b], np.float64),
                               np.array(hits[a:b])) for a, b in zip(bounds[:-1], bounds[1:])]
    mapper.odometry = [tuple(p) for p in odometry]
    mapper.travel = list(travel)
    mapper.grid = mapper.rendered()
    mapper.restart_odometry()
    return mapper
