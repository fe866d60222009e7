// DoF facts from GET /api/robot and the dopesheet's row groups.
import { describe, expect, it } from "vitest";
import type { DofInfo as ApiDof } from "../../generated/api";
import { dofInfos, groupRows } from "./dofs";

const api = (d: Partial<ApiDof> & Pick<ApiDof, "name" | "type" | "dimension">): ApiDof => ({
  acceleration: null, channels: [0, 1], jerk: null, max: null, min: null, rest: null, velocity: null, ...d,
});

const robot = {
  dofs: [
    api({ name: "body_yaw", type: "continuous", dimension: "stationary", joint: "body_yaw", min: -2.6, max: 2.6, rest: 0, velocity: 1.6 }),
    api({ name: "gaze_yaw", type: "continuous", dimension: "stationary", drives: { body_yaw: 0.3 }, min: -1.5, max: 1.5, rest: 0, velocity: 3 }),
    api({ name: "base_x", type: "continuous", dimension: "spatial", min: -0.5, max: 0.5, rest: 0, velocity: 0.25 }),
    api({ name: "eye_leds", type: "colour", dimension: "display", min: 0, max: 1, rest: [0.35, 0.75, 1], velocity: 20 }),
    api({ name: "mouth", type: "enum", dimension: "display", min: 0, max: 2, rest: 1, options: ["neutral", "smile", "grin"] }),
    api({ name: "speech", type: "event", dimension: "audible" }),
    api({ name: "head_pitch", type: "continuous", dimension: "stationary", joint: "head_pitch", rest: 0.1, description: "nods" }),
  ],
};

describe("dofInfos", () => {
  it("skips event DoFs, groups the rest and fills limits and rest values", () => {
    const infos = dofInfos(robot);
    expect(infos.map((d) => [d.name, d.group])).toEqual([
      ["body_yaw", "Joints"], ["gaze_yaw", "Symbolic"], ["base_x", "Spatial"], ["eye_leds", "Display"],
      ["mouth", "Display"], ["head_pitch", "Joints"],
    ]);
    const byName = new Map(infos.map((d) => [d.name, d]));
    expect(byName.get("eye_leds")).toMatchObject({ type: "colour", rest: 0.35, restValue: [0.35, 0.75, 1] });
    expect(byName.get("mouth")).toMatchObject({ type: "enum", rest: 1, restValue: "smile", options: ["neutral", "smile", "grin"], velocity: Infinity });
    expect(byName.get("head_pitch")).toMatchObject({ min: -Infinity, max: Infinity, rest: 0.1, description: "nods" });
  });
});

describe("groupRows", () => {
  it("orders groups stably, keeps the robot's order, and shows tracks the robot lacks under Other", () => {
    const infos = dofInfos(robot);
    const rows = groupRows(infos, { zzz: [{ t: 0, v: "x" }], mouth: [{ t: 0, v: "grin" }] });
    expect(rows.map((r) => [r.group, r.dofs.map((d) => d.name)])).toEqual([
      ["Joints", ["body_yaw", "head_pitch"]], ["Symbolic", ["gaze_yaw"]], ["Spatial", ["base_x"]],
      ["Display", ["eye_leds", "mouth"]], ["Other", ["zzz"]],
    ]);
    expect(rows[4].dofs[0]).toMatchObject({ type: "enum", options: ["x"] });
    expect(groupRows(infos, { mouth: [{ t: 0, v: "grin" }] }, { onlyKeyed: true })).toEqual([
      { group: "Display", dofs: [infos[4]] },
    ]);
  });
});
