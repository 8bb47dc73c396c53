"""prt: Precomputed Radiance Transfer from Python (docs/PYTHON.md).

Maps, meshes and transfer files as numpy arrays, and the computations of the
prt command (project, precompute, relight, reference) with its defaults and
its results: the same inputs give the same numbers as the command line.

    import prt
    mesh = prt.load_mesh("models/scene.obj")
    t = prt.precompute(mesh, bands=3, samples=256, progress=True)
    light = prt.project(prt.data_dir() + "/envmaps/sunset.exr", t.bands)
    rgb = prt.relight(t, mesh, light)            # (V, 3) float32

Errors in the inputs (a bad file, a bad value) raise prt.Error, a
RuntimeError whose message names the file or argument.
"""
from ._prt import (  # noqa: F401
    MAX_BANDS,
    EnvMap,
    Error,
    Lightmap,
    Mesh,
    ProbeVolume,
    Scene,
    Transfer,
    WaveletTransfer,
    ZhTransfer,
    __version__,
    compress,
    compression_error,
    data_dir,
    deform,
    export_gltf,
    export_web,
    fit_zh,
    info,
    load_envmap,
    lightmap_from_rows,
    load_mesh,
    load_scene,
    make_mesh,
    pose,
    precompute,
    precompute_lightmap,
    precompute_probes,
    project,
    read_lightmap,
    read_probes,
    read_transfer,
    read_wavelet,
    read_zh,
    read_vertex_csv,
    reference,
    relight,
    render,
    rotate_sh,
    rotation_from_euler,
    sh_eval,
    verify,
    write_vertex_csv,
)

__all__ = [
    "MAX_BANDS", "EnvMap", "Error", "Lightmap", "Mesh", "ProbeVolume", "Scene", "Transfer", "lightmap_from_rows", "load_scene",
    "precompute_lightmap", "precompute_probes", "read_lightmap", "read_probes", "__version__", "data_dir", "load_envmap", "load_mesh",
    "make_mesh", "precompute", "project", "read_transfer", "read_vertex_csv", "reference", "relight", "rotate_sh",
    "rotation_from_euler", "sh_eval", "write_vertex_csv", "ZhTransfer", "deform", "fit_zh", "pose", "read_zh",
    "WaveletTransfer", "read_wavelet", "compress", "compression_error",
    "info", "verify", "render", "export_gltf", "export_web",
]
