// The Pre-Viz's sound switch: the live robot's speech and sounds played by the browser (off until a
// click, as browsers allow audio only after one). The choice is remembered; when it was on, the first
// click anywhere on the next visit turns audio on again.
import { useEffect, useState } from "react";
import { call, type SoundEntry } from "../api";
import { preload } from "./liveAudio";
import { setMuted, unlock } from "./soundPlayer";

const STORAGE_KEY = "nutty.sound/1";

function remembered(): boolean {
  try {
    return window.localStorage.getItem(STORAGE_KEY) === "on";
  } catch {
    return false;  // no storage: off
  }
}

async function turnOn(): Promise<void> {
  await unlock();
  setMuted(false);
  const sounds = await call<SoundEntry[]>("GET", "/api/sounds").catch(() => []);
  preload(sounds.map((s) => s.url));
}

export function SoundToggle() {
  const [on, setOn] = useState(remembered);
  useEffect(() => {
    setMuted(!on);
    try {
      window.localStorage.setItem(STORAGE_KEY, on ? "on" : "off");
    } catch {
      // no storage: the choice lasts this visit
    }
    if (!on) return;
    // audio may start only from a user gesture: the click on this switch, or the first one after a reload
    const again = () => { void turnOn(); };
    window.addEventListener("pointerdown", again, { once: true });
    return () => window.removeEventListener("pointerdown", again);
  }, [on]);
  return (
    <button type="button" data-testid="previz-sound" aria-pressed={on}
            title={on ? "mute the robot's speech and sounds" : "hear the robot's speech and sounds in step with the motion"}
            onClick={() => { if (!on) void turnOn(); setOn(!on); }}>
      {on ? "♪ sound on" : "♪ sound off"}
    </button>
  );
}
