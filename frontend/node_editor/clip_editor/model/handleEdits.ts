// Edits of a key's interpolation and handles. Whenever a handle becomes free or aligned its offset is
// written out as the curve currently shows it (from resolveHandles, what Python evaluates), so the
// stored document fully describes the curve the user sees and changing a type never makes it jump.
import { resolveHandles } from "./curve";
import { mapSelected } from "./tracks";
import type { Clip, Edited, Handle, HandleType, KeyRef, Keyframe, Side } from "./types";

export type KeyProps = Partial<Pick<Keyframe, "interp" | "easing" | "left_type" | "right_type">>;

const typeKey = (side: Side) => (side === "left" ? "left_type" : "right_type");
const other = (side: Side): Side => (side === "left" ? "right" : "left");
const length = (h: Handle): number => Math.hypot(h[0], h[1]);
const GIVEN: readonly HandleType[] = ["aligned", "free"];

/** A handle of `len` pointing opposite `h` (zero when h has no direction). */
function mirror(h: Handle, len: number): Handle {
  const n = length(h);
  return n === 0 ? [0, 0] : [(-h[0] / n) * len, (-h[1] / n) * len];
}

/** Key i's handles as offsets, as the curve shows them. A side clamped to nothing (the outer side of an
 * end key) gets the mirror of the other side instead: Python aligns a side to the other's *stored*
 * offset, so a stored zero would flatten the visible side. */
export function shownOffsets(keys: readonly Keyframe[], i: number): { left: Handle; right: Handle } {
  const k = keys[i];
  const v = Number(k.v);
  const h = resolveHandles(keys)[i];
  let left: Handle = [h.left[0] - k.t, h.left[1] - v];
  let right: Handle = [h.right[0] - k.t, h.right[1] - v];
  if (length(left) === 0 && length(right) > 0) left = mirror(right, length(right));
  else if (length(right) === 0 && length(left) > 0) right = mirror(left, length(left));
  return { left, right };
}

const storedHandle = (k: Keyframe, side: Side): Handle | null => {
  const h = k[side];
  return h == null ? null : [Number(h[0]), Number(h[1])];
};

/** Set interp, easing and/or handle types of the selected keys. auto/auto_clamped/vector drop that
 * side's stored offset; aligned/free without one store the handle as shown. */
export function setKeyProps(doc: Clip, sel: readonly KeyRef[], props: KeyProps): Edited {
  return mapSelected(doc, sel, (k, dof) => {
    const keys = doc.tracks[dof];
    const out: Keyframe = { ...k };
    if (props.interp !== undefined) out.interp = props.interp;
    if (props.easing !== undefined) out.easing = props.easing;
    let shown: { left: Handle; right: Handle } | null = null;
    for (const side of ["left", "right"] as const) {
      const type = props[typeKey(side)];
      if (type === undefined) continue;
      out[typeKey(side)] = type;
      if (!GIVEN.includes(type)) delete out[side];
      else if (out[side] == null && typeof k.v === "number") {
        shown ??= shownOffsets(keys, keys.indexOf(k));
        out[side] = shown[side];
      }
    }
    return out;
  });
}

/** Drag one handle of a numeric key to the absolute point [t, v]. Its offset's time is kept on its
 * side (left <= 0, right >= 0). An auto/auto_clamped/vector handle becomes aligned on both sides (as in
 * Blender) and the segments the handle shapes become bezier (the key's own; for a left handle also the
 * previous key's). When either side is aligned the other side is written as the exact opposite
 * direction, keeping its length; a free handle next to a free one moves alone. */
export function dragHandle(
  doc: Clip,
  ref: KeyRef,
  side: Side,
  point: Handle,
  sel: readonly KeyRef[] = [ref],
): Edited {
  const keys = doc.tracks[ref.dof];
  const k = keys?.[ref.index];
  if (!k || typeof k.v !== "number") return { doc, selection: [...sel] };
  const dt = point[0] - k.t;
  const off: Handle = [side === "left" ? Math.min(dt, 0) : Math.max(dt, 0), point[1] - k.v];
  const os = other(side);
  const shown = shownOffsets(keys, ref.index);
  let thisType = k[typeKey(side)] ?? "auto_clamped";
  let otherType = k[typeKey(os)] ?? "auto_clamped";
  if (!GIVEN.includes(thisType)) {
    thisType = "aligned";
    otherType = "aligned";
  }
  const out: Keyframe = { ...k, interp: "bezier", [typeKey(side)]: thisType, [typeKey(os)]: otherType, [side]: off };
  if ((thisType === "aligned" || otherType === "aligned") && length(off) > 0) {
    const stored = storedHandle(k, os);
    const len =
      stored && length(stored) > 0 ? length(stored) : length(shown[os]) > 0 ? length(shown[os]) : length(off);
    out[os] = mirror(off, len);
  } else if (GIVEN.includes(otherType) && k[os] == null) {
    out[os] = shown[os];
  }
  const next = keys.map((key, i) => {
    if (i === ref.index) return out;
    if (side === "left" && i === ref.index - 1) return { ...key, interp: "bezier" as const };
    return key;
  });
  return { doc: { ...doc, tracks: { ...doc.tracks, [ref.dof]: next } }, selection: [...sel] };
}
