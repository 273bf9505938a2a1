"""Shared fixtures: the shared data directory, the real PETS clip, and tiny clip builders.

- ``shared_data``: ``../shared/data`` beside the repository (or ``$MVTRACK_SHARED_DATA``); tests
  using it skip with a stated reason when it is absent.
- ``pets_clip``: the PETS 2009 S2L1 clip written once per session by
  ``shared/data/pets2009-s2l1/to_clip.py --link-video`` (all views).
- ``clip_builder``: writes small clips into ``tmp_path``: videos and frame folders whose frames
  encode their stream index (``encode_index`` / ``decode_index``), clip.toml, detections CSVs.
"""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Iterable
from pathlib import Path

import cv2
import numpy as np
import pytest
from hypothesis import settings

# Property tests explore new random examples on every local run; CI (CI=true, as .ci/run sets)
# replays a fixed sequence so that a submission's result does not depend on luck.
settings.register_profile("ci", derandomize=True, database=None)
if os.environ.get("CI", "").lower() in ("1", "true"):
    settings.load_profile("ci")

SIZE = (320, 240)  # width, height of generated test frames
_BITS = 12  # frame indices up to 4095; one vertical stripe per bit


def _shared_data_dir() -> Path | None:
    beside = Path(__file__).resolve().parents[2] / "shared" / "data"
    if beside.is_dir():
        return beside
    env = os.environ.get("MVTRACK_SHARED_DATA")
    return Path(env) if env and Path(env).is_dir() else None


@pytest.fixture(scope="session")
def shared_data() -> Path:
    """The shared data directory; skips the test when it is absent."""
    path = _shared_data_dir()
    if path is None:
        pytest.skip(
            "shared data not found: expected ../shared/data beside the repository "
            "or the MVTRACK_SHARED_DATA environment variable"
        )
    return path


@pytest.fixture(scope="session")
def pets_clip(shared_data: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The PETS 2009 S2L1 mvtrack clip (View_001 video symlinked, 6 detections cameras)."""
    script = shared_data / "pets2009-s2l1" / "to_clip.py"
    if not script.is_file():
        pytest.skip(f"{script} not found in the shared data")
    out = tmp_path_factory.mktemp("pets") / "clip"
    subprocess.run(
        [sys.executable, str(script), str(out), "--link-video"],
        check=True,
        capture_output=True,
        timeout=120,
    )
    return out


def encode_index(index: int, size: tuple[int, int] = SIZE, channels: int = 3) -> np.ndarray:
    """A frame whose vertical stripes spell ``index`` in binary (white = 1), robust to codecs.

    Returns (H, W, 3) uint8 (or (H, W) when ``channels`` is 1).
    """
    w, h = size
    bits = (index >> np.arange(_BITS)) & 1
    row = np.repeat(bits * 255, w // _BITS).astype(np.uint8)
    row = np.pad(row, (0, w - row.size))
    image = np.tile(row, (h, 1))
    return image if channels == 1 else np.repeat(image[:, :, None], channels, axis=2)


def decode_index(image: np.ndarray) -> int:
    """The index :func:`encode_index` wrote, read from the centre of each stripe."""
    gray = image if image.ndim == 2 else image.mean(axis=2)
    w = image.shape[1]
    stripe = w // _BITS
    centres = np.arange(_BITS) * stripe + stripe // 2
    bits = gray[:, centres].mean(axis=0) > 127
    return int(np.sum(bits.astype(np.int64) << np.arange(_BITS)))


class ClipBuilder:
    """Writes small test clips under one root directory."""

    size = SIZE
    encode = staticmethod(encode_index)
    decode = staticmethod(decode_index)

    def __init__(self, root: Path) -> None:
        self.root = root
        root.mkdir(parents=True, exist_ok=True)

    def video(
        self,
        name: str,
        n: int,
        fourcc: str = "mp4v",
        fps: float = 12.5,
        size: tuple[int, int] = SIZE,
    ) -> Path:
        """A video of ``n`` index-encoded frames (``name`` with its extension)."""
        path = self.root / name
        writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*fourcc), fps, size)
        assert writer.isOpened(), f"cannot write {path} with {fourcc}"
        for i in range(n):
            writer.write(encode_index(i, size))
        writer.release()
        return path

    def frames(self, name: str, n: int, ext: str = ".png", size: tuple[int, int] = SIZE) -> Path:
        """A frame folder of ``n`` index-encoded images named 000000.png ..."""
        folder = self.root / name
        folder.mkdir(parents=True, exist_ok=True)
        for i in range(n):
            cv2.imwrite(str(folder / f"{i:06d}{ext}"), encode_index(i, size))
        return folder

    def toml(self, text: str) -> Path:
        path = self.root / "clip.toml"
        path.write_text(text, encoding="utf-8")
        return path

    def detections(self, rel: str, rows: Iterable[str]) -> Path:
        """A detections CSV with the standard header and the given row lines."""
        path = self.root / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        lines = ["frame,x,y,w,h,score,foot_x,foot_y,track", *rows]
        path.write_text("\n".join(lines) + "\n", encoding="utf-8")
        return path


@pytest.fixture
def clip_builder(tmp_path: Path) -> ClipBuilder:
    """A :class:`ClipBuilder` writing into ``tmp_path / "clip"``."""
    return ClipBuilder(tmp_path / "clip")
