"""Every file format: volumes (.npy/.npz, VDB, HDF5/NetCDF), EXR/PNG, video, atomic writes."""
