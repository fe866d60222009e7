// Tests of the timeline's pure layout: lanes, bar boxes, summaries and the relative-timing links.
import { describe, expect, it } from "vitest";
import { BAR_HEIGHT, FLAG_WIDTH, LANE_HEIGHT, barBox, describeStart, itemSummary, laneAt, laneMid, linkFor } from "./layout";

const view = { t0: 0, t1: 10 };

describe("layout", () => {
  it("stacks lanes and finds the lane under a pointer", () => {
    expect(BAR_HEIGHT).toBeGreaterThanOrEqual(22);
    expect(BAR_HEIGHT).toBeLessThanOrEqual(26);
    expect(laneMid(2)).toBe(2.5 * LANE_HEIGHT);
    expect(laneAt(0, 3)).toBe(0);
    expect(laneAt(LANE_HEIGHT * 1.5, 3)).toBe(1);
    expect(laneAt(LANE_HEIGHT * 10, 3)).toBe(2);
    expect(laneAt(-5, 3)).toBe(0);
  });

  it("spans a bar over [start, end] and centres an instant's flag on its time", () => {
    expect(barBox(view, 1000, "play_clip", 1, 3)).toEqual({ x: 100, width: 200, instant: false });
    expect(barBox(view, 1000, "set_face", 2, 2)).toEqual({ x: 200 - FLAG_WIDTH / 2, width: FLAG_WIDTH, instant: true });
    expect(barBox(view, 1000, "say", 2, 2).instant).toBe(true);
    expect(barBox({ t0: 0, t1: 1000 }, 1000, "say", 0, 0.1).width).toBe(4);
    expect(barBox({ t0: -1, t1: 9 }, 1000, "wait", 0, 1).x).toBe(100);
  });

  it("summarises items by their label or what they do", () => {
    expect(itemSummary({ id: "a", kind: "say", text: "Hello there my good friend" })).toBe("“Hello there my good…”");
    expect(itemSummary({ id: "a", kind: "say", text: "Hi", label: "greeting" })).toBe("greeting");
    expect(itemSummary({ id: "a", kind: "play_clip", clip: "wave" })).toBe("wave");
    expect(itemSummary({ id: "a", kind: "set_led", colour: [1, 0.8, 0.2] })).toBe("LED [1, 0.8, 0.2]");
    expect(itemSummary({ id: "a", kind: "play_sound", sound: "beep" })).toBe("♪ beep");
    expect(itemSummary({ id: "a", kind: "ramp", input: "energy", to: 1 })).toBe("energy → 1");
  });

  it("describes starts", () => {
    expect(describeStart(1.5)).toBe("1.5 s");
    expect(describeStart({ item: "wave", at: "anchor", anchor: "beat", offset: -0.2 })).toBe("wave.beat − 0.2 s");
    expect(describeStart({ item: "look", at: "end" })).toBe("look.end");
  });

  it("links a relative item to its reference's moment", () => {
    const wave = { id: "wave", track: 1, kind: "play_clip", start: 1, end: 3, anchors: { beat: 2 } };
    const hello = { id: "hello", track: 2, kind: "say", start: 2.5, end: 4 };
    const item = { id: "hello", kind: "say" as const, text: "hi", start: { item: "wave", at: "anchor" as const, anchor: "beat", offset: 0.5 } };
    expect(linkFor(item, hello, wave, view, 1000, (p) => p.track)).toEqual({
      from: "wave", to: "hello", x1: 200, y1: laneMid(1), x2: 250, y2: laneMid(2),
    });
    expect(linkFor({ ...item, start: 2 }, hello, wave, view, 1000, (p) => p.track)).toBeNull();
    expect(linkFor(item, hello, undefined, view, 1000, (p) => p.track)).toBeNull();
  });
});
