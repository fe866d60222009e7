// Where a new item goes: the lane named for its kind when the behaviour has one (a say on "voice", a
// clip on "body"...), else the selected item's lane, else the first. Pure; tested with vitest.
import type { BehaviourDoc, ItemKind } from "./model/types";

const LANES: Record<ItemKind, string[]> = {
  play_clip: ["body", "motion", "clip", "clips"],
  go_posture: ["body", "posture", "motion"],
  look_at: ["gaze", "eyes", "look"],
  say: ["voice", "speech", "say"],
  play_sound: ["sound", "sounds", "sfx", "voice"],
  set_led: ["lights", "leds", "led", "face"],
  set_face: ["face", "display"],
  set_emotion: ["mood", "emotion"],
  ramp: ["inputs", "ramps", "mood"],
  wait: ["timing", "waits"],
};

export function trackForKind(doc: BehaviourDoc, kind: ItemKind, selectedTrack: number | null): number {
  const names = (doc.tracks ?? []).map((t) => t.name.toLowerCase());
  for (const lane of LANES[kind]) {
    const i = names.indexOf(lane);
    if (i >= 0) return i;
  }
  return selectedTrack !== null && selectedTrack < names.length ? selectedTrack : 0;
}
