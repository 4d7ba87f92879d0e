"""The one table of file formats the package reads and writes, by suffix."""

from __future__ import annotations

#: Volume inputs: NumPy (``io.volumes``), OpenVDB/NanoVDB (``io.vdb``), HDF5 and NetCDF
#: (``io.scientific``, extra "science").
NUMPY_SUFFIXES = (".npy", ".npz")
VDB_SUFFIXES = (".vdb", ".nvdb")
HDF5_SUFFIXES = (".h5", ".hdf5")
NETCDF_SUFFIXES = (".nc", ".nc4")
SCIENCE_SUFFIXES = HDF5_SUFFIXES + NETCDF_SUFFIXES
#: VTK files and ParaView collections, OpenFOAM case markers (``io.vtk``, extra "vtk"); an
#: OpenFOAM case folder or time folder is read too.
VTK_SUFFIXES = (".vti", ".vtk", ".vtu", ".vts", ".vtr")
PVD_SUFFIXES = (".pvd",)
OPENFOAM_SUFFIXES = (".foam", ".openfoam")
VTK_INPUT_SUFFIXES = VTK_SUFFIXES + PVD_SUFFIXES + OPENFOAM_SUFFIXES
VOLUME_SUFFIXES = NUMPY_SUFFIXES + VDB_SUFFIXES + SCIENCE_SUFFIXES + VTK_INPUT_SUFFIXES
#: Scene files (``config``).
SCENE_SUFFIXES = (".toml", ".json")
#: Rendered images (``incandescent.output``): scene-linear EXR, display PNG.
IMAGE_SUFFIXES = (".exr", ".png")
#: Videos (``io.video``); any other animation output is a folder of PNG frames.
VIDEO_SUFFIXES = (".mp4", ".gif")
#: Render statistics (``--stats``).
STATS_SUFFIXES = (".json",)
