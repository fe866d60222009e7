// Unit tests of the behaviour model: edits (immutability, ids, dangling references, renames), retiming
// (absolute rounding, relative offsets, snapping, cycles, negative starts) and snap targets.
import { describe, expect, it } from "vitest";
import { addItem, addTrack, moveItemToTrack, newItemId, removeItem, removeTrack, renameItem, renameTrack, updateItem } from "./edits";
import { findItem } from "./refs";
import { retime } from "./retime";
import { nearestSnap, snapTargets } from "./snap";
import type { BehaviourDoc, Plan } from "./types";

// greet.json's shape: look -> wave (from look's end - 0.3) -> hello (wave's anchor "beat"), smile/happy.
function greet(): BehaviourDoc {
  return {
    format: "nutty-behaviour/1",
    description: "greet",
    tracks: [
      { name: "gaze", items: [{ id: "look", kind: "look_at", target: "{target}", duration: 0.8 }] },
      { name: "body", items: [{ id: "wave", kind: "play_clip", clip: "wave", start: { item: "look", at: "end", offset: -0.3 } }] },
      { name: "voice", items: [{ id: "hello", kind: "say", text: "Hello {name}!", start: { item: "wave", at: "anchor", anchor: "beat", offset: 0 } }] },
      { name: "face", items: [{ id: "smile", kind: "set_face", expression: "smile", start: { item: "wave", at: "start" } }] },
      { name: "mood", items: [{ id: "happy", kind: "set_emotion", valence: 0.7, arousal: 0.3, start: { item: "hello", at: "start", offset: 0.25 } }] },
    ],
  };
}

const plan: Plan = {
  valid: true,
  duration: 3.1,
  params: {},
  items: [
    { id: "look", track: 0, kind: "look_at", start: 0, end: 0.8 },
    { id: "wave", track: 1, kind: "play_clip", start: 0.5, end: 2.5, anchors: { beat: 1.2 } },
    { id: "smile", track: 3, kind: "set_face", start: 0.5, end: 0.5 },
    { id: "hello", track: 2, kind: "say", start: 1.2, end: 3.1 },
    { id: "happy", track: 4, kind: "set_emotion", start: 1.45, end: 1.45 },
  ],
  errors: [],
};

const frozen = (): BehaviourDoc => JSON.parse(JSON.stringify(greet()), (_, v) => (typeof v === "object" && v ? Object.freeze(v) : v));

describe("edits", () => {
  it("never mutate the input", () => {
    const doc = frozen();
    expect(() => {
      addTrack(doc, "extra");
      addItem(doc, 0, "say", 1, {});
      removeItem(doc, "wave", plan);
      updateItem(doc, "hello", { text: "Hi" });
      renameItem(doc, "wave", "wave2");
      moveItemToTrack(doc, "smile", 0);
      removeTrack(doc, 1, plan);
      renameTrack(doc, 0, "eyes");
    }).not.toThrow();
  });

  it("add tracks with unique names", () => {
    const doc = addTrack(addTrack(greet(), "voice"), "voice");
    expect(doc.tracks?.map((t) => t.name).slice(5)).toEqual(["voice_2", "voice_3"]);
  });

  it("rename a track unless the name is taken or no identifier", () => {
    expect(renameTrack(greet(), 0, "eyes").tracks?.[0].name).toBe("eyes");
    const doc = greet();
    expect(renameTrack(doc, 0, "body")).toBe(doc);
    expect(renameTrack(doc, 0, "has space")).toBe(doc);
    expect(renameTrack(doc, 9, "x")).toBe(doc);
  });

  it("add items with fresh ids and the kind's required fields", () => {
    let doc = addItem(greet(), 2, "say", 1.23456, { text: "Hi" });
    expect(findItem(doc, "say")?.item).toEqual({ id: "say", kind: "say", start: 1.235, text: "Hi" });
    expect(newItemId(doc, "say")).toBe("say_2");
    doc = addItem(doc, 2, "say", 2);
    expect(doc.tracks?.[2].items?.map((i) => i.id)).toEqual(["hello", "say", "say_2"]);
    doc = addItem(doc, 1, "play_clip", -3, { clip: "nod" });
    expect(findItem(doc, "clip")?.item).toMatchObject({ kind: "play_clip", clip: "nod", start: 0 });
    expect(findItem(addItem(doc, 0, "go_posture", 0, { posture: "rest" }), "posture")?.item).toMatchObject({ posture: "rest" });
    expect(findItem(addItem(doc, 0, "play_sound", 0, { sound: "beep" }), "sound")?.item).toMatchObject({ sound: "beep" });
    expect(findItem(addItem(doc, 0, "set_led", 0), "led")?.item).toMatchObject({ colour: [1, 1, 1] });
    expect(addItem(doc, 7, "wait", 0)).toBe(doc);
  });

  it("remove an item, giving the items timed from it their planned absolute start", () => {
    const doc = removeItem(greet(), "wave", plan);
    expect(findItem(doc, "wave")).toBeNull();
    expect(findItem(doc, "hello")?.item.start).toBe(1.2);
    expect(findItem(doc, "smile")?.item.start).toBe(0.5);
    // timed from hello, which stays: untouched
    expect(findItem(doc, "happy")?.item.start).toEqual({ item: "hello", at: "start", offset: 0.25 });
  });

  it("remove an item without a plan of its dependent: the removed moment plus the offset", () => {
    const partial: Plan = { ...plan, items: plan.items.filter((p) => p.id !== "happy") };
    expect(findItem(removeItem(greet(), "hello", partial), "happy")?.item.start).toBe(1.45);
    expect(findItem(removeItem(greet(), "hello", null), "happy")?.item.start).toBe(0);
  });

  it("remove a track and detach what was timed from its items", () => {
    const doc = removeTrack(greet(), 1, plan);
    expect(doc.tracks?.map((t) => t.name)).toEqual(["gaze", "voice", "face", "mood"]);
    expect(findItem(doc, "hello")?.item.start).toBe(1.2);
  });

  it("update fields, removing those set to undefined, never the id or kind", () => {
    let doc = updateItem(greet(), "hello", { text: "Hi", audio: "hi_rec", label: "greeting" });
    expect(findItem(doc, "hello")?.item).toMatchObject({ text: "Hi", audio: "hi_rec", label: "greeting" });
    doc = updateItem(doc, "hello", { audio: undefined, id: "x", kind: "wait" });
    const item = findItem(doc, "hello")?.item;
    expect(item && "audio" in item).toBe(false);
    expect(item?.kind).toBe("say");
  });

  it("rename an item and the references to it", () => {
    const doc = renameItem(greet(), "wave", "wave_hi");
    expect(findItem(doc, "wave_hi")?.item.kind).toBe("play_clip");
    expect(findItem(doc, "hello")?.item.start).toMatchObject({ item: "wave_hi", anchor: "beat" });
    expect(findItem(doc, "smile")?.item.start).toMatchObject({ item: "wave_hi" });
    const same = greet();
    expect(renameItem(same, "wave", "hello")).toBe(same);
    expect(renameItem(same, "wave", "9bad")).toBe(same);
  });

  it("move an item to another track", () => {
    const doc = moveItemToTrack(greet(), "smile", 4);
    expect(doc.tracks?.[3].items).toEqual([]);
    expect(doc.tracks?.[4].items?.map((i) => i.id)).toEqual(["happy", "smile"]);
  });
});

describe("retime", () => {
  it("moves an absolute start, rounded to 1 ms", () => {
    expect(findItem(retime(greet(), plan, "look", 0.12345, null), "look")?.item.start).toBe(0.123);
  });

  it("keeps a relative start's reference and changes its offset", () => {
    const doc = retime(greet(), plan, "wave", 0.9004, null);
    expect(findItem(doc, "wave")?.item.start).toEqual({ item: "look", at: "end", offset: 0.1 });
    const anchored = retime(greet(), plan, "hello", 1.0, null);
    expect(findItem(anchored, "hello")?.item.start).toEqual({ item: "wave", at: "anchor", anchor: "beat", offset: -0.2 });
  });

  it("snaps onto another item's start, end or anchor with offset 0", () => {
    let doc = retime(greet(), plan, "happy", 1.2, { item: "wave", at: "anchor", anchor: "beat", t: 1.2 });
    expect(findItem(doc, "happy")?.item.start).toEqual({ item: "wave", at: "anchor", anchor: "beat", offset: 0 });
    doc = retime(greet(), plan, "look", 0.5, { item: "smile", at: "start", t: 0.5 });
    // smile is timed from wave, which is timed from look: a circle, refused
    expect(doc).toEqual(greet());
    doc = retime(greet(), plan, "smile", 3.1, { item: "hello", at: "end", t: 3.1 });
    expect(findItem(doc, "smile")?.item.start).toEqual({ item: "hello", at: "end", offset: 0 });
  });

  it("refuses cycles, self references, unknown items and negative starts", () => {
    const doc = greet();
    expect(retime(doc, plan, "wave", 1, { item: "wave", at: "start", t: 0.5 })).toBe(doc);
    expect(retime(doc, plan, "wave", 1, { item: "happy", at: "start", t: 1.45 })).toBe(doc);
    expect(retime(doc, plan, "look", -0.5, null)).toBe(doc);
    expect(retime(doc, plan, "nope", 1, null)).toBe(doc);
    expect(retime(doc, plan, "smile", 1, { item: "ghost", at: "start", t: 1 })).toBe(doc);
  });

  it("uses the item's own plan when its reference's is missing", () => {
    const partial: Plan = { ...plan, items: plan.items.filter((p) => p.id !== "hello") };
    const doc = retime(greet(), partial, "happy", 2, null);
    expect(findItem(doc, "happy")?.item.start).toEqual({ item: "hello", at: "start", offset: 0.8 });
  });
});

describe("snap", () => {
  it("lists other items' moments, never the moving item's or its dependents'", () => {
    const targets = snapTargets(plan, "wave", greet());
    expect(targets.map((t) => `${t.item}.${t.at}${t.anchor ? `.${t.anchor}` : ""}`)).toEqual(["look.start", "look.end"]);
    const all = snapTargets(plan, "happy", greet());
    expect(all).toContainEqual({ item: "wave", at: "anchor", anchor: "beat", t: 1.2 });
    expect(all.some((t) => t.item === "happy")).toBe(false);
    // an instant item has one moment
    expect(all.filter((t) => t.item === "smile")).toEqual([{ item: "smile", at: "start", t: 0.5 }]);
    expect(snapTargets(plan, "wave").some((t) => t.item === "hello")).toBe(true);
  });

  it("picks the nearest target within the pixel radius", () => {
    const targets = snapTargets(plan, "happy", greet());
    expect(nearestSnap(targets, 1.25, 100)).toMatchObject({ item: "wave", anchor: "beat" });
    expect(nearestSnap(targets, 1.3, 100)).toBeNull();
    expect(nearestSnap(targets, 1.3, 100, 12)).toMatchObject({ t: 1.2 });
    expect(nearestSnap(targets, 0.78, 100)).toMatchObject({ item: "look", at: "end" });
    expect(nearestSnap([], 1, 100)).toBeNull();
  });
});
