// The graph editor's toolbar (interpolation, easing and handle type of the selected keys, the curves'
// legend and the trajectory helper's) and the T / V pop-up menus offering the same choices.
import type { FilteredTracks, TrackAnalysis } from "../../generated/api";
import type { Clip, Easing, HandleType, Interp, KeyRef } from "../model/types";

export const INTERPS: Interp[] = ["constant", "linear", "bezier", "sine", "quad", "cubic", "quart", "quint", "expo", "circ", "back", "elastic", "bounce"];
export const EASINGS: Easing[] = ["in", "out", "in_out"];
export const HANDLE_TYPES: HandleType[] = ["auto", "auto_clamped", "vector", "aligned", "free"];

export type KeyProps = { interp?: Interp; easing?: Easing; left_type?: HandleType; right_type?: HandleType };

/** The value every selected key shares for a property (with the format's default), or "" when mixed. */
export function common(doc: Clip, sel: readonly KeyRef[], get: (k: Clip["tracks"][string][number]) => string): string {
  let out: string | null = null;
  for (const r of sel) {
    const k = doc.tracks[r.dof]?.[r.index];
    if (!k) continue;
    const v = get(k);
    if (out === null) out = v;
    else if (out !== v) return "";
  }
  return out ?? "";
}

export interface ToolbarProps {
  doc: Clip;
  selection: KeyRef[];
  apply: (props: KeyProps, label: string) => void;
  legend: { dof: string; colour: string }[];
  helper: TrackAnalysis | null;
  ghost: FilteredTracks | null;
}

export function GraphToolbar({ doc, selection, apply, legend, helper, ghost }: ToolbarProps) {
  const none = selection.length === 0;
  const interp = common(doc, selection, (k) => k.interp ?? "bezier");
  const easing = common(doc, selection, (k) => k.easing ?? "in_out");
  const lt = common(doc, selection, (k) => k.left_type ?? "auto_clamped");
  const rt = common(doc, selection, (k) => k.right_type ?? "auto_clamped");
  const handle = lt === rt ? lt : "";
  const kinds = helper ? [...new Set(helper.ranges.map((r) => r.kind))] : [];
  return (
    <div className="graph-toolbar">
      <label title="Interpolation of the segments leaving the selected keys (T)">
        Interp
        <select data-testid="graph-interp" value={interp} disabled={none}
                onChange={(e) => e.target.value && apply({ interp: e.target.value as Interp }, "Set interpolation")}>
          <option value="" disabled>—</option>
          {INTERPS.map((i) => <option key={i} value={i}>{i}</option>)}
        </select>
      </label>
      <label title="Easing of the easing presets">
        Easing
        <select data-testid="graph-easing" value={easing} disabled={none}
                onChange={(e) => e.target.value && apply({ easing: e.target.value as Easing }, "Set easing")}>
          <option value="" disabled>—</option>
          {EASINGS.map((i) => <option key={i} value={i}>{i}</option>)}
        </select>
      </label>
      <label title="Handle type of both sides of the selected keys (V)">
        Handles
        <select data-testid="graph-handle" value={handle} disabled={none}
                onChange={(e) => {
                  const h = e.target.value as HandleType;
                  if (h) apply({ left_type: h, right_type: h }, "Set handle type");
                }}>
          <option value="" disabled>—</option>
          {HANDLE_TYPES.map((i) => <option key={i} value={i}>{i}</option>)}
        </select>
      </label>
      <span className="graph-legend">
        {legend.map((l) => (
          <span key={l.dof} className="legend-item"><i style={{ background: l.colour }} />{l.dof}</span>
        ))}
        {ghost && <span className="legend-item ghost" title="the engine's filtered output (dashed)"><i />ghost {ghost.preset}</span>}
        {kinds.map((k) => (
          <span key={k} className="legend-item"><i style={{ background: helper?.colours[k] ?? "#e5484d" }} />{k}</span>
        ))}
        {helper && !helper.ok && helper.suggestion && <span className="legend-note" title={helper.suggestion}>⚠ {helper.suggestion}</span>}
      </span>
    </div>
  );
}

export interface MenuState {
  kind: "interp" | "handle";
  x: number;
  y: number;
}

/** The pop-up T (interpolation) or V (handle type) menu at the pointer. */
export function GraphMenu({ menu, apply, close }: { menu: MenuState; apply: (props: KeyProps, label: string) => void; close: () => void }) {
  const items: string[] = menu.kind === "interp" ? INTERPS : HANDLE_TYPES;
  const pick = (v: string) => {
    if (menu.kind === "interp") apply({ interp: v as Interp }, "Set interpolation");
    else apply({ left_type: v as HandleType, right_type: v as HandleType }, "Set handle type");
    close();
  };
  return (
    <div className="graph-menu" data-testid="graph-menu" style={{ left: menu.x, top: menu.y }}
         onPointerDown={(e) => e.stopPropagation()}>
      <div className="graph-menu-title">{menu.kind === "interp" ? "Interpolation" : "Handle type"}</div>
      {items.map((v) => (
        <button key={v} type="button" data-testid={`graph-menu-${v}`} onClick={() => pick(v)}>{v}</button>
      ))}
    </div>
  );
}
