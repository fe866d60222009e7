import { describe, expect, it } from "vitest";
import { ApiError } from "../api";
import { errorKeyOf, refusalOf } from "./clipErrors";

describe("errorKeyOf", () => {
  it("maps a key's field to dof#index", () => {
    expect(errorKeyOf("tracks.head_pitch.2.t")).toBe("head_pitch#2");
    expect(errorKeyOf("tracks.head_pitch.0.v")).toBe("head_pitch#0");
    expect(errorKeyOf("tracks.head_pitch.3")).toBe("head_pitch#3");
  });

  it("maps a track's field to the dof", () => {
    expect(errorKeyOf("tracks.head_pitch")).toBe("head_pitch");
  });

  it("maps anything else to the clip as a whole", () => {
    expect(errorKeyOf("anchors.down")).toBe("");
    expect(errorKeyOf("events.0.t")).toBe("");
    expect(errorKeyOf("tracks")).toBe("");
    expect(errorKeyOf(null)).toBe("");
    expect(errorKeyOf(undefined)).toBe("");
  });

  it("reads FastAPI's body locations and DoF names with dots", () => {
    expect(errorKeyOf("body.tracks.eye.left.1.t", ["eye.left"])).toBe("eye.left#1");
    expect(errorKeyOf("tracks.eye.left", ["eye.left"])).toBe("eye.left");
  });
});

describe("refusalOf", () => {
  it("turns the server's detail into a message and keyed errors", () => {
    const e = new ApiError(422, { code: "invalid_clip", message: "invalid clip: keys out of order", field: "tracks.neck.1.t" });
    expect(refusalOf(e)).toEqual({ message: "invalid clip: keys out of order", errors: { "neck#1": "invalid clip: keys out of order" } });
  });

  it("reads FastAPI's list of issues", () => {
    const e = new ApiError(422, [{ loc: ["body", "tracks", "neck"], msg: "bad" }] as unknown as null);
    const r = refusalOf(e);
    expect(r.errors).toEqual({ neck: "body.tracks.neck: bad" });
  });

  it("keeps a network error as the clip's error", () => {
    expect(refusalOf(new Error("offline"))).toEqual({ message: "offline", errors: { "": "offline" } });
  });
});
