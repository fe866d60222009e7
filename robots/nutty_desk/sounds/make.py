"""Remake this folder's sounds: the sound effects are synthesised here; the recorded speech is
espeak-ng 1.51 (Debian package `espeak-ng`) speaking the lines below. Run from anywhere:

    python robots/nutty_desk/sounds/make.py

Everything is written as Ogg Vorbis (small, and decoded by libsndfile everywhere).
"""

from __future__ import annotations

import subprocess
import tempfile
from pathlib import Path

import numpy as np
import soundfile

HERE = Path(__file__).resolve().parent
SR = 22050
LINES = {  # sound name -> what espeak-ng says (voice en+f3: a light, friendly voice)
    "speech_thinking": "Hmm. Let me think about that.",
    "speech_hooray": "Hooray! We did it!",
    "speech_sleepy": "I'm getting so sleepy. Good night.",
    "speech_hello": "Hello there! It's nice to see you.",
}


def envelope(n: int, attack: float, release: float) -> np.ndarray:
    t = np.arange(n) / SR
    return np.minimum(1.0, t / attack) * np.exp(-np.maximum(0.0, t - attack) / release)


def chirp() -> np.ndarray:
    t = np.arange(int(0.35 * SR)) / SR
    f = 900 + 1800 * (t / t[-1]) ** 1.5
    return 0.5 * np.sin(2 * np.pi * np.cumsum(f) / SR) * envelope(t.size, 0.01, 0.12)


def beep() -> np.ndarray:
    t = np.arange(int(0.25 * SR)) / SR
    return 0.4 * np.sin(2 * np.pi * 1320 * t) * envelope(t.size, 0.005, 0.2)


def purr() -> np.ndarray:
    t = np.arange(int(1.6 * SR)) / SR
    rng = np.random.default_rng(1)
    noise = np.convolve(rng.standard_normal(t.size), np.ones(40) / 40, mode="same")
    am = 0.5 + 0.5 * np.sin(2 * np.pi * 24 * t)  # the purr's flutter
    swell = np.sin(np.pi * t / t[-1]) ** 0.7
    return 0.9 * noise * am * swell + 0.15 * np.sin(2 * np.pi * 70 * t) * am * swell


def yawn() -> np.ndarray:
    t = np.arange(int(1.8 * SR)) / SR
    f = 260 + 160 * np.sin(np.pi * np.minimum(1.0, t / 1.3)) - 120 * (t / t[-1])
    phase = 2 * np.pi * np.cumsum(f) / SR
    voice = sum(np.sin(k * phase) / k for k in range(1, 6))
    return 0.25 * voice * np.sin(np.pi * t / t[-1]) ** 0.8


def giggle() -> np.ndarray:
    parts = []
    for k in range(5):
        t = np.arange(int(0.11 * SR)) / SR
        f = 620 - 30 * k + 180 * np.sin(np.pi * t / t[-1])
        phase = 2 * np.pi * np.cumsum(f) / SR
        burst = sum(np.sin(j * phase) / j for j in range(1, 4)) * np.sin(np.pi * t / t[-1])
        parts += [0.3 * burst, np.zeros(int(0.05 * SR))]
    return np.concatenate(parts)


def speak(text: str) -> tuple[np.ndarray, int]:
    with tempfile.TemporaryDirectory() as tmp:
        wav = Path(tmp) / "line.wav"
        subprocess.run(["espeak-ng", "-v", "en+f3", "-s", "150", "-w", str(wav), text], check=True)
        data, rate = soundfile.read(wav, dtype="float32")
    return data, rate


def main() -> None:
    for name, make in {"chirp": chirp, "beep": beep, "purr": purr, "yawn": yawn, "giggle": giggle}.items():
        soundfile.write(HERE / f"{name}.ogg", np.clip(make(), -1, 1).astype(np.float32), SR, format="OGG")
    for name, text in LINES.items():
        data, rate = speak(text)
        soundfile.write(HERE / f"{name}.ogg", data, rate, format="OGG")


if __name__ == "__main__":
    main()
