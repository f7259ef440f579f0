# SPDX-License-Identifier: GPL-3.0-or-later
"""Point-cache files: vertex positions per frame in the PC2 and MDD formats. numpy only.

Blender 4.2 and newer no longer bundle the PC2/MDD exporters (they became an extension), but
its built-in *Mesh Cache* modifier still reads both formats, so the bake writes them here.

PC2 (little-endian)::

    char[12] "POINTCACHE2\\0" · int32 version = 1 · int32 points · float32 start frame ·
    float32 sampling (frames between samples) · int32 samples · float32 xyz[samples][points]

MDD (big-endian)::

    int32 frames · int32 points · float32 time in seconds[frames] · float32 xyz[frames][points]

Positions are in the object's space, in the mesh's vertex order, exactly as given (float32,
no axis change: the Mesh Cache modifier's default Forward +Y / Up +Z reads them as they are).

A writer streams frame by frame into ``<path>.partial`` and only :meth:`CacheWriter.close`
gives the file its name, so a cancelled or failed bake never leaves a half-written cache, and
an existing file of that name stays as it was until the new one is complete.
"""

import os
import struct

import numpy as np

PC2_MAGIC = b"POINTCACHE2\0"
_PC2_HEADER = struct.Struct("<12siiffi")
_MDD_HEADER = struct.Struct(">ii")
PARTIAL_SUFFIX = ".partial"


class CacheWriter:
    """Writes `frame_count` frames of `points` positions, one :meth:`write` per frame."""

    #: numpy dtype of the positions in the file (byte order included).
    dtype = None

    def __init__(self, path, points, frame_count):
        if points <= 0 or frame_count <= 0:
            raise ValueError(f"a cache needs points and frames (got {points} points, {frame_count} frames)")
        self.path, self.points, self.frame_count = path, int(points), int(frame_count)
        self.partial_path = path + PARTIAL_SUFFIX
        self.written = 0
        self._file = open(self.partial_path, "wb")
        try:
            self._file.write(self._header())
        except BaseException:
            self.abort()
            raise

    def _header(self):
        raise NotImplementedError

    def write(self, positions):
        """Appends one frame: (points, 3) positions (converted to float32)."""
        positions = np.asarray(positions)
        if positions.shape != (self.points, 3):
            raise ValueError(f"frame {self.written}: {positions.shape} positions, the cache holds ({self.points}, 3)")
        if self.written >= self.frame_count:
            raise ValueError(f"the cache holds {self.frame_count} frames; all are written")
        self._file.write(positions.astype(self.dtype, copy=False).tobytes())
        self.written += 1

    def close(self):
        """Finishes the file and gives it its name (replacing an older file of that name)."""
        if self.written != self.frame_count:
            raise ValueError(f"{self.written} of {self.frame_count} frames written")
        self._file.close()
        os.replace(self.partial_path, self.path)

    def abort(self):
        """Closes and deletes the partial file; the file at `path` is left as it was."""
        if not self._file.closed:
            self._file.close()
        if os.path.exists(self.partial_path):
            os.remove(self.partial_path)


class PC2Writer(CacheWriter):
    """PC2: `start` is the first frame's number, `sampling` the frames between samples."""

    dtype = np.dtype("<f4")

    def __init__(self, path, points, frame_count, start, sampling=1.0):
        self.start, self.sampling = float(start), float(sampling)
        super().__init__(path, points, frame_count)

    def _header(self):
        return _PC2_HEADER.pack(PC2_MAGIC, 1, self.points, self.start, self.sampling, self.frame_count)


class MDDWriter(CacheWriter):
    """MDD: `times` are the frames' times in seconds (one per frame)."""

    dtype = np.dtype(">f4")

    def __init__(self, path, points, times):
        self.times = np.asarray(times, dtype=np.float64)
        super().__init__(path, points, len(self.times))

    def _header(self):
        return _MDD_HEADER.pack(self.frame_count, self.points) + self.times.astype(">f4").tobytes()


def read_pc2(path):
    """(start, sampling, positions (samples, points, 3) float32) of a PC2 file."""
    with open(path, "rb") as f:
        data = f.read()
    magic, version, points, start, sampling, samples = _PC2_HEADER.unpack_from(data)
    if magic != PC2_MAGIC or version != 1:
        raise ValueError(f"{path}: not a PC2 version 1 file")
    body = np.frombuffer(data, dtype="<f4", offset=_PC2_HEADER.size)
    if body.size != samples * points * 3:
        raise ValueError(f"{path}: {body.size} floats for {samples} samples of {points} points")
    return start, sampling, body.reshape(samples, points, 3).astype(np.float32)


def read_mdd(path):
    """(times (frames,) float32 seconds, positions (frames, points, 3) float32) of an MDD file."""
    with open(path, "rb") as f:
        data = f.read()
    frames, points = _MDD_HEADER.unpack_from(data)
    times = np.frombuffer(data, dtype=">f4", count=frames, offset=_MDD_HEADER.size)
    body = np.frombuffer(data, dtype=">f4", offset=_MDD_HEADER.size + 4 * frames)
    if frames < 0 or points < 0 or body.size != frames * points * 3:
        raise ValueError(f"{path}: {body.size} floats for {frames} frames of {points} points")
    return times.astype(np.float32), body.reshape(frames, points, 3).astype(np.float32)
