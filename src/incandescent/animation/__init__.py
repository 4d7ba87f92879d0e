"""Rendering sequences of volumes: resumable frames, one camera and one exposure, then video.

- :mod:`.sequence`: frame files, their manifest and keys, the folder's lock, resume, read-ahead;
- :mod:`.video`: :func:`animate` (the missing frames, then the MP4/GIF), :func:`assemble_video`;
- :mod:`.render`: :func:`fixed_display`, :func:`render_video` and :class:`SequenceJob` (a
  sequence of volume files, which builds each frame's cluster :class:`FrameTask`);
- :mod:`.plate`: the 2011 paper's plate video.
"""

from incandescent.animation.plate import plate_camera, render_plate_video
from incandescent.animation.render import (
    CameraPath,
    FrameTask,
    SequenceJob,
    fixed_display,
    render_video,
    sequence_job,
    video_scene,
)
from incandescent.animation.sequence import (
    FRAME_HEAP_BYTES,
    FRAME_NAME,
    LOCK_NAME,
    MANIFEST_NAME,
    Distribute,
    FramesFailed,
    PathLike,
    RenderFrame,
    VolumeSource,
    _ahead,
    _render_missing,
    expand_sequence,
    file_identity,
    frame_key,
    frame_path,
    keep_frame_memory,
    key_frame,
    plan_output,
    record_frames,
    render_sequence,
)
from incandescent.animation.video import AnimationSummary, animate, assemble_video

__all__ = [
    "FRAME_HEAP_BYTES",
    "FRAME_NAME",
    "LOCK_NAME",
    "MANIFEST_NAME",
    "AnimationSummary",
    "CameraPath",
    "Distribute",
    "FrameTask",
    "FramesFailed",
    "PathLike",
    "RenderFrame",
    "SequenceJob",
    "VolumeSource",
    "_ahead",
    "_render_missing",
    "animate",
    "assemble_video",
    "expand_sequence",
    "file_identity",
    "fixed_display",
    "frame_key",
    "frame_path",
    "keep_frame_memory",
    "key_frame",
    "plan_output",
    "plate_camera",
    "record_frames",
    "render_plate_video",
    "render_sequence",
    "render_video",
    "sequence_job",
    "video_scene",
]
