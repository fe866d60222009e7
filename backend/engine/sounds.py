"""A robot's sounds as audio files: `robots/<robot>/sounds/<name>.wav|ogg|flac`, decoded by libsndfile
(the `soundfile` package).

Each sound is checked when it is stored (`save`: a WAV, Ogg Vorbis/Opus or FLAC file libsndfile can
decode, at most MAX_BYTES and MAX_SECONDS) and measured once: its length, and its *envelope* at an
engine rate, the smoothed RMS loudness per tick that recorded speech moves the mouth by (`envelope`).
Names are restricted like the other assets, so a request never escapes the folder.
"""

from __future__ import annotations

import contextlib
import io
import os
import re
import tempfile
import threading
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import soundfile

from backend.engine.asset_errors import LibraryError, NotFound

EXTENSIONS = {".wav": "WAV", ".ogg": "OGG", ".flac": "FLAC"}
MEDIA_TYPES = {"WAV": "audio/wav", "OGG": "audio/ogg", "FLAC": "audio/flac"}
MAX_BYTES = 20 * 1024 * 1024
MAX_SECONDS = 300.0
_NAME = re.compile(r"^[A-Za-z0-9_][A-Za-z0-9_\-]{0,79}$")
#: the envelope's smoothing: a centred moving average over this many seconds (no lag: the whole file
#: is known), and the level (fraction of the loud end) below which the mouth stays shut
SMOOTHING = 0.05
GATE = 0.08
LOUD_PERCENTILE = 95.0


class SoundError(LibraryError):
    """A sound that cannot be stored or read; `code` says which way (`too_large`, `too_long`,
    `invalid_audio`, `invalid_name`)."""

    def __init__(self, message: str, code: str = "invalid_audio"):
        super().__init__(message, field="body" if code != "invalid_name" else "name")
        self.code = code


@dataclass(frozen=True)
class SoundInfo:
    name: str
    path: Path
    format: str  # WAV, OGG or FLAC
    samplerate: int  # Hz
    channels: int
    frames: int
    mtime: float

    @property
    def duration(self) -> float:
        """s"""
        return self.frames / self.samplerate if self.samplerate else 0.0

    @property
    def media_type(self) -> str:
        return MEDIA_TYPES.get(self.format, "application/octet-stream")

    def to_dict(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "format": self.format.lower(),
            "duration": round(self.duration, 4),
            "samplerate": self.samplerate,
            "channels": self.channels,
            "bytes": self.path.stat().st_size if self.path.exists() else 0,
            "url": sound_url(self.name),
        }


def sound_url(name: str) -> str:
    """Where a client fetches a sound from the server (relative to the server's address)."""
    return f"/api/sounds/{name}"


def check_name(name: Any) -> str:
    if not isinstance(name, str) or not _NAME.match(name):
        raise SoundError(
            f"invalid sound name {name!r}: use letters, digits, '_' or '-', at most 80 characters",
            code="invalid_name",
        )
    return name


def probe(data: bytes) -> soundfile.SoundFile:
    """Open audio bytes for reading, or SoundError saying why they are not a sound we store."""
    if len(data) > MAX_BYTES:
        raise SoundError(
            f"the file is {len(data) / 1e6:.1f} MB: at most {MAX_BYTES // 2**20} MB", "too_large"
        )
    if not data:
        raise SoundError("the body is empty: send the audio file's bytes")
    try:
        f = soundfile.SoundFile(io.BytesIO(data))
    except (soundfile.LibsndfileError, RuntimeError, TypeError) as exc:
        raise SoundError(f"not an audio file libsndfile can read (WAV, Ogg or FLAC): {exc}") from exc
    if f.format not in EXTENSIONS.values():
        f.close()
        raise SoundError(f"{f.format} audio: store WAV, Ogg (Vorbis or Opus) or FLAC")
    if f.samplerate <= 0 or f.frames <= 0:
        f.close()
        raise SoundError("the file holds no audio")
    if f.frames / f.samplerate > MAX_SECONDS:
        seconds = f.frames / f.samplerate
        f.close()
        raise SoundError(f"the sound lasts {seconds:.1f} s: at most {MAX_SECONDS:g} s", "too_long")
    return f


class SoundLibrary:
    """The sounds of one robot folder (`folder` None: a robot without one). Thread-safe."""

    def __init__(self, folder: str | Path | None):
        self.folder = Path(folder) if folder is not None else None
        self._lock = threading.Lock()
        self._info: dict[str, SoundInfo] = {}
        self._envelopes: dict[tuple[str, float, float], np.ndarray] = {}
        self.warming: threading.Thread | None = None  # `warm`'s thread

    def _files(self) -> dict[str, Path]:
        if self.folder is None or not self.folder.is_dir():
            return {}
        found: dict[str, Path] = {}
        for p in sorted(self.folder.iterdir()):
            if p.suffix.lower() in EXTENSIONS and _NAME.match(p.stem) and p.is_file():
                found.setdefault(p.stem, p)
        return found

    def list(self) -> list[str]:
        return sorted(self._files())

    def warm(self) -> threading.Thread:
        """Read every sound's facts on a thread of their own (returned, started): the clock thread looks
        a sound up when it plays, and reading its file there the first time cost 1-2 ms of a 2 ms tick."""

        def read_all() -> None:
            for name, path in self._files().items():  # one look at the folder, one read per file
                with contextlib.suppress(SoundError):  # a broken file is reported when asked for
                    self._read(name, path)

        self.warming = threading.Thread(target=read_all, name="nutty-sounds", daemon=True)
        self.warming.start()
        return self.warming

    def find(self, name: str) -> SoundInfo | None:
        """The sound's facts, or None when there is no such (readable) file."""
        try:
            return self.info(name)
        except LibraryError:
            return None

    def has(self, name: str) -> bool:
        return self.find(name) is not None

    def info(self, name: str) -> SoundInfo:
        """The sound's facts (cached until its file changes); NotFound, or SoundError for a broken file."""
        check_name(name)
        cached = self._info.get(name)
        if cached is not None and cached.path.exists() and cached.path.stat().st_mtime == cached.mtime:
            return cached
        path = self._files().get(name)
        if path is None:
            raise NotFound(f"no sound named '{name}'")
        return self._read(name, path)

    def _read(self, name: str, path: Path) -> SoundInfo:
        """Read the facts of sound `name` from its file `path`, and keep them."""
        try:
            with soundfile.SoundFile(path) as f:
                info = SoundInfo(
                    name, path, f.format, f.samplerate, f.channels, f.frames, path.stat().st_mtime
                )
        except (soundfile.LibsndfileError, RuntimeError) as exc:
            raise SoundError(f"sounds/{path.name} cannot be read: {exc}") from exc
        self._info[name] = info
        return info

    def samples(self, name: str) -> tuple[np.ndarray, int]:
        """(mono samples in -1..1, sample rate in Hz) of a sound."""
        info = self.info(name)
        data, rate = soundfile.read(info.path, dtype="float32", always_2d=True)
        return data.mean(axis=1), int(rate)

    def envelope(self, name: str, rate: float, smoothing: float = SMOOTHING) -> np.ndarray:
        """The sound's loudness per engine tick at `rate` Hz, in 0..1 (see `loudness`). Computed once
        per sound, rate and file version; a read-only array of ceil(duration * rate) values."""
        info = self.info(name)
        key = (name, float(rate), float(smoothing))
        env = self._envelopes.get(key)
        if env is not None and self._info.get(name) is info:
            return env
        samples, sr = self.samples(name)
        env = loudness(samples, sr, rate, smoothing)
        env.setflags(write=False)
        with self._lock:
            self._envelopes[key] = env
        return env

    def save(self, name: str, data: bytes) -> SoundInfo:
        """Store audio bytes as `name` (replacing any file of that name, whatever its format)."""
        check_name(name)
        if self.folder is None:
            raise SoundError("this robot has no library folder (it was loaded from a bare URDF)")
        with probe(data) as f:
            ext = next(e for e, fmt in EXTENSIONS.items() if fmt == f.format)
            f.read(frames=min(f.frames, 4096))  # the first block decodes: a truncated header is caught
        with self._lock:
            self.folder.mkdir(parents=True, exist_ok=True)
            fd, tmp = tempfile.mkstemp(dir=self.folder, prefix=f".{name}.", suffix=".tmp")
            try:
                os.fchmod(fd, 0o644)
                with os.fdopen(fd, "wb") as fh:
                    fh.write(data)
                os.replace(tmp, self.folder / f"{name}{ext}")
            except BaseException:
                Path(tmp).unlink(missing_ok=True)
                raise
            for other in EXTENSIONS:
                if other != ext:
                    (self.folder / f"{name}{other}").unlink(missing_ok=True)
            self._forget(name)
        return self.info(name)

    def delete(self, name: str) -> None:
        check_name(name)
        with self._lock:
            path = self._files().get(name)
            if path is None:
                raise NotFound(f"no sound named '{name}'")
            path.unlink()
            self._forget(name)

    def _forget(self, name: str) -> None:
        self._info.pop(name, None)
        for key in [k for k in self._envelopes if k[0] == name]:
            del self._envelopes[key]


def loudness(samples: np.ndarray, samplerate: int, rate: float, smoothing: float = SMOOTHING) -> np.ndarray:
    """Smoothed RMS loudness of `samples` per tick of `rate` Hz, in 0..1.

    RMS over each tick's samples, smoothed by a centred moving average of `smoothing` s, scaled so the
    loud end (the 95th percentile of the voiced ticks) is 1, with levels under GATE closed to 0."""
    hop = samplerate / rate
    n = max(1, int(np.ceil(len(samples) / hop)))
    edges = np.minimum(np.round(np.arange(n + 1) * hop).astype(np.int64), len(samples))
    power = np.concatenate(([0.0], np.cumsum(samples.astype(np.float64) ** 2)))
    counts = np.maximum(edges[1:] - edges[:-1], 1)
    rms = np.sqrt((power[edges[1:]] - power[edges[:-1]]) / counts)
    width = max(1, round(smoothing * rate))
    if width > 1:
        kernel = np.ones(width) / width
        rms = np.convolve(
            np.pad(rms, (width // 2, width - 1 - width // 2), mode="edge"), kernel, mode="valid"
        )
    voiced = rms[rms > 0.02 * rms.max()] if rms.max() > 0 else rms
    loud = float(np.percentile(voiced, LOUD_PERCENTILE)) if voiced.size else 0.0
    if loud <= 1e-9:
        return np.zeros(n)
    level = np.clip(rms / loud, 0.0, 1.0)
    return np.where(level < GATE, 0.0, (level - GATE) / (1.0 - GATE))
