"""File input/output: EXR and PNG images (atomic writes, metadata in headers)."""
