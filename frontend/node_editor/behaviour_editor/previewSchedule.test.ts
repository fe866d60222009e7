import { describe, expect, it } from "vitest";
import type { RenderEvent } from "./behaviourApi";
import { audioUrl, audioUrls, eventsBetween, frameAt, soundingAt, spokenText } from "./previewSchedule";

const ev = (t: number, kind: string, payload: RenderEvent["payload"]): RenderEvent => ({ t, dof: kind === "say" ? "speech" : "sound", kind, payload });
const giggle = ev(0.26, "sound", { sound: "giggle", url: "/api/sounds/giggle", duration: 0.8 });
const hooray = ev(0.45, "say", { text: "Hooray!", sound: "speech_hooray", url: "/api/sounds/speech_hooray", duration: 2 });
const hello = ev(1.05, "say", { text: "Hello friend!" });
const events = [giggle, hooray, hello];

describe("preview scheduling", () => {
  it("each event fires in exactly one of consecutive ticks", () => {
    const ticks = [0, 0.2, 0.45, 0.9, 1.05, 2];
    const fired = ticks.slice(1).flatMap((to, i) => eventsBetween(events, ticks[i], to));
    expect(fired).toEqual([giggle, hooray, hello]);
    expect(eventsBetween(events, 0.2, 0.45)).toEqual([giggle]);
    expect(eventsBetween(events, 0.45, 0.9)).toEqual([hooray]);
  });

  it("a preview started mid-sound picks it up part-way; speech without audio is not resumed", () => {
    const s = soundingAt(events, 1.2);
    expect(s.map((x) => x.event)).toEqual([hooray]);
    expect(s[0].offset).toBeCloseTo(0.75);
    expect(soundingAt(events, 0.26)).toEqual([]);
  });

  it("knows each event's audio: a file, or the browser's voice", () => {
    expect(audioUrl(giggle)).toBe("/api/sounds/giggle");
    expect(spokenText(hooray)).toBeNull();
    expect(spokenText(hello)).toBe("Hello friend!");
    expect(audioUrls({ events: [...events, giggle] })).toEqual(["/api/sounds/giggle", "/api/sounds/speech_hooray"]);
  });

  it("the pose at a time is the nearest frame, clamped, without unusable values", () => {
    const r = { rate: 10, dofs: ["a", "led", "face"], frames: [[0, [1, 0, 0], "smile"], [0.5, [0, 1, 0], null]] };
    expect(frameAt(r, 0.04)).toEqual({ a: 0, led: [1, 0, 0], face: "smile" });
    expect(frameAt(r, 7)).toEqual({ a: 0.5, led: [0, 1, 0] });
    expect(frameAt({ ...r, frames: [] }, 0)).toBeNull();
  });
});
