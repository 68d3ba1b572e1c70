"""Read a sylva dataset directory from Python: numpy arrays, and PyTorch datasets when torch is
importable. Install: ``pip install -e python/`` (docs/outputs.md, "The Python package")::

    import sylva_dataset as sd

    ds = sd.Dataset("out/demo")          # dataset.json (ds.info) + every complete manifest record;
                                         # packed ([outputs] pack = "tar") or not, read alike
    len(ds), ds.species                  # instance count, species names (first-seen order)
    for inst in ds:                      # Instance objects, in manifest (= instance) order
        inst.id, inst.species, inst.index, inst.seed, inst.record, inst.stats["height_m"]
        sk = inst.skeleton()             # positions (N,3) f32, radii f32, parents i64 (−1 root),
                                         # edges (E,2) i64, order i64, part i64
        m = inst.mesh()                  # first listed format; inst.mesh("glb"),
                                         # inst.mesh("watertight", "obj"): positions (V,3) f32,
                                         # faces (F,3) i64, normals, uvs, order, part, colour
        inst.points()                    # positions (P,3) f32, labels i64, views i64
        inst.cameras()                   # transforms.json (dict)
        inst.scan()                      # scan.las: positions (P,3) f64, classification,
                                         # tree_id, semantic, … i64 (sylva_dataset.Scan)
        inst.masks(), inst.labels()      # lists of (H, W) uint8 views, in frame order
        inst.rgb()                       # colour pictures ([views] colour): (H, W, 4) uint8
        inst.depths()                    # list of (H, W) float32 depth views (metres, 0 = none)

    from sylva_dataset.pytorch import TreeDataset, ViewDataset, ShardDataset   # needs torch

Low-level readers, each of a path or a file's bytes: read_ply, read_png, read_exr, read_mesh
(ply / glb / obj), read_las, read_colour. Tar shards: shard_list, iter_shard, tar_members,
member_name.
"""

from .dataset import MESH_FORMATS, Dataset, Instance, PointCloud, Scan, Skeleton, read_colour
from .exr import read_exr, read_exr_first_channel
from .las import LasFile, read_las
from .meshes import Mesh, read_glb, read_mesh, read_obj
from .ply import read_ply
from .png import read_png
from .shards import TarShards, iter_shard, member_name, shard_list, tar_members

__version__ = "0.3.0"

__all__ = ["Dataset", "Instance", "Skeleton", "Mesh", "PointCloud", "Scan", "MESH_FORMATS", "read_ply",
           "read_las", "LasFile", "read_colour",
           "read_png", "read_exr", "read_exr_first_channel", "read_mesh", "read_glb", "read_obj",
           "TarShards", "iter_shard", "member_name", "shard_list", "tar_members",
           "torch_available"]


def torch_available():
    """True when PyTorch is importable, i.e. sylva_dataset.pytorch can be used."""
    try:
        import torch  # noqa: F401
    except ImportError:
        return False
    return True
