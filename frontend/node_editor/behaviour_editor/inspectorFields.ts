// Which fields the inspector shows for each item kind, how each is edited (a select of what the robot
// has, a number, a point/colour, text) and how typed text becomes the document's value: a number, a
// list of three numbers, or text (a "{param}" reference stays text). Pure; tested with vitest.
import type { ItemKind } from "./model/types";

export type FieldEditor =
  /** one of the robot's clips / postures / sounds / the program's inputs (a "{param}" is kept) */
  | { type: "select"; source: "clips" | "postures" | "sounds" | "inputs" | "expressions"; optional?: boolean }
  | { type: "choice"; choices: string[]; optional?: boolean }
  | { type: "number"; optional?: boolean }
  /** [x, y, z] / [r, g, b], or a name or "{param}" */
  | { type: "triple"; optional?: boolean }
  /** a number or [x, y, z] (a ramp's `to`), or a name */
  | { type: "numberOrTriple" }
  | { type: "text"; optional?: boolean; long?: boolean };

export interface FieldSpec { field: string; label: string; editor: FieldEditor }

const f = (field: string, label: string, editor: FieldEditor): FieldSpec => ({ field, label, editor });

export const KIND_FIELDS: Record<ItemKind, FieldSpec[]> = {
  play_clip: [f("clip", "Clip", { type: "select", source: "clips" }), f("speed", "Speed", { type: "number", optional: true }),
    f("crossfade", "Crossfade (s)", { type: "number", optional: true }), f("fade_out", "Fade out (s)", { type: "number", optional: true }),
    f("layer", "Layer", { type: "text", optional: true })],
  go_posture: [f("posture", "Posture", { type: "select", source: "postures" }), f("duration", "Duration (s)", { type: "number", optional: true }),
    f("easing", "Easing", { type: "text", optional: true })],
  look_at: [f("target", "Target", { type: "triple" }), f("duration", "Duration (s)", { type: "number", optional: true })],
  say: [f("text", "Text", { type: "text", long: true }), f("audio", "Recorded audio", { type: "select", source: "sounds", optional: true })],
  play_sound: [f("sound", "Sound", { type: "select", source: "sounds" })],
  set_led: [f("colour", "Colour (r, g, b)", { type: "triple" }), f("dof", "LED DoF", { type: "text", optional: true })],
  set_face: [f("expression", "Expression", { type: "select", source: "expressions" }), f("dof", "Display DoF", { type: "text", optional: true })],
  set_emotion: [f("valence", "Valence", { type: "number" }), f("arousal", "Arousal", { type: "number" })],
  ramp: [f("input", "Input", { type: "select", source: "inputs" }), f("to", "To", { type: "numberOrTriple" }),
    f("duration", "Duration (s)", { type: "number", optional: true }), f("easing", "Easing", { type: "choice", choices: ["linear", "smooth"], optional: true })],
  wait: [f("duration", "Duration (s)", { type: "number", optional: true })],
};

const NUMBER = /^[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?$/;

/** A field's value as text in its input. */
export function fieldText(value: unknown): string {
  if (value === undefined || value === null) return "";
  if (Array.isArray(value)) return value.map(String).join(", ");
  return String(value);
}

/** Typed text as the field's value: undefined clears an optional field (back to its default); text
 * that is no number where one is wanted stays text (a "{param}"; the server reports what is wrong). */
export function parseField(editor: FieldEditor, text: string): unknown {
  const t = text.trim();
  if (t === "" && "optional" in editor && editor.optional) return undefined;
  if (editor.type === "text") return text;
  if (editor.type === "number") return NUMBER.test(t) ? Number(t) : t;
  if (editor.type === "triple" || editor.type === "numberOrTriple") {
    if (editor.type === "numberOrTriple" && NUMBER.test(t)) return Number(t);
    const parts = t.replace(/^\[|\]$/g, "").split(/[\s,]+/).filter(Boolean);
    if (parts.length === 3 && parts.every((p) => NUMBER.test(p))) return parts.map(Number);
    return t;
  }
  return t;
}
