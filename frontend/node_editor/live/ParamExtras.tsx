// The parameter panel's live parts: "driven by <node>.<port>" for a parameter a wire overrides, and the
// layer mixer's layer stack (instead of its layers as raw JSON).
import { useContext, useState } from "react";
import type { LayerState } from "../api";
import { LiveContext } from "../context";
import { NumberField } from "../fields/NumberField";
import type { NumberSpec } from "../fields/numberField";
import { useFocusNode } from "./focus";
import { setSolo, useLiveUi } from "./liveUi";
import { maskSummary, moved, mutePlan, soloPlan, summarise, unsoloPlan, type Driver } from "./logic";

/** A parameter whose same-named input is wired: the wire's source, its live value, a jump to it. */
export function DrivenBy({ param, driver }: { param: string; driver: Driver }) {
  const live = useContext(LiveContext);
  const focus = useFocusNode();
  return (
    <div className="driven-by" data-testid={`driven-${param}`}
         title="the wire into the input of the same name overrides this parameter while it is connected">
      <span>driven by <b>{driver.node}.{driver.port}</b></span>
      <span className="driven-value" data-testid={`driven-value-${param}`}>{summarise(live.values[`${driver.node}.${driver.port}`])}</span>
      <button type="button" data-testid={`driven-jump-${param}`} title={`select ${driver.node}`}
              onClick={(e) => { e.preventDefault(); focus(driver.node); }}>→ {driver.node}</button>
    </div>
  );
}

/** A layer mixer's layer as its `layers` parameter holds it. */
export type Layer = Record<string, unknown> & { name: string };

const MODES = ["override", "additive", "average"];
/** A layer's weight and its fade time (s), as the mixer's schema bounds them. */
const WEIGHT: NumberSpec = { softMin: 0, softMax: 1, hardMin: 0, hardMax: 1, step: 0.01 };
const FADE: NumberSpec = { hardMin: 0, hardMax: 30, step: 0.1 };

/** The layer mixer's layers, bottom to top: mode, weight, fade, mask, mute/solo, the live weight. */
export function LayerStack({ node, layers, onChange }: {
  node: string; layers: Layer[]; onChange: (layers: Layer[], live: boolean) => void;
}) {
  const live = useContext(LiveContext);
  const ui = useLiveUi();
  const states: LayerState[] = live.layers[node] ?? [];
  const stateOf = (name: string) => states.find((s) => s.name === name);
  const activeNow = layers.map((l) => ({ name: l.name, active: stateOf(l.name)?.active ?? (l.active !== false) }));
  const send = (sw: { layer: string; active: boolean }) => live.setLayer?.(node, sw.layer, sw.active);
  const solo = ui.solo[node];
  const toggleSolo = (name: string) => {
    if (solo?.layer === name) {
      unsoloPlan(activeNow, solo.saved).forEach(send);
      setSolo(node, null);
    } else {
      const plan = soloPlan(activeNow, name);
      plan.switches.forEach(send);
      setSolo(node, { layer: name, saved: solo ? solo.saved : plan.saved });
    }
  };
  const edit = (i: number, patch: Record<string, unknown>, isLive: boolean) =>
    onChange(layers.map((l, k) => (k === i ? { ...l, ...patch } : l)), isLive);
  return (
    <div className="layer-stack" data-testid={`layer-stack-${node}`}>
      <div className="ls-note muted">bottom to top: later layers override earlier ones</div>
      {layers.map((l, i) => {
        const st = stateOf(l.name);
        const active = activeNow[i].active;  // as it runs (commands may have switched it)
        const written = l.active !== false;  // as the program says
        const weight = typeof l.weight === "number" ? l.weight : 1;
        return (
          <div key={l.name} className={`ls-row ${active ? "" : "muted-layer"} ${solo?.layer === l.name ? "soloed" : ""}`}
               data-testid={`ls-${l.name}`} data-active={active ? "1" : "0"}>
            <div className="ls-line">
              <span className="ls-order">
                <button type="button" aria-label={`move ${l.name} up`} data-testid={`ls-up-${l.name}`} disabled={i === 0}
                        onClick={() => onChange(moved(layers, i, -1), false)}>▲</button>
                <button type="button" aria-label={`move ${l.name} down`} data-testid={`ls-down-${l.name}`} disabled={i === layers.length - 1}
                        onClick={() => onChange(moved(layers, i, 1), false)}>▼</button>
              </span>
              <span className="ls-name" title={`layer ${l.name}: input port '${l.name}'`}>{l.name}</span>
              <select aria-label={`${l.name} mode`} data-testid={`ls-mode-${l.name}`} value={String(l.mode ?? "override")}
                      onChange={(e) => edit(i, { mode: e.target.value }, false)}>
                {MODES.map((m) => <option key={m} value={m}>{m}</option>)}
              </select>
              {/* mute is the layer's `active` parameter: saved with the program and undoable */}
              <button type="button" className={`ls-toggle ${written ? "" : "on"}`} data-testid={`ls-mute-${l.name}`}
                      title={written ? "mute: fade this layer out (saved in the program)" : "unmute: fade this layer in"}
                      onClick={() => edit(i, { active: mutePlan({ name: l.name, active: written }).active }, false)}>M</button>
              <button type="button" className="ls-toggle" data-testid={`ls-remove-${l.name}`} disabled={layers.length === 1}
                      title="remove this layer (its input and the wire to it go too)"
                      onClick={() => onChange(layers.filter((_, k) => k !== i), false)}>×</button>
              <button type="button" className={`ls-toggle ${solo?.layer === l.name ? "on solo" : ""}`} data-testid={`ls-solo-${l.name}`}
                      title={solo?.layer === l.name ? "un-solo: bring the other layers back" : "solo: only this layer"}
                      onClick={() => toggleSolo(l.name)}>S</button>
            </div>
            <div className="ls-line">
              <NumberField testId={`ls-weight-${l.name}`} label="weight" labelClass="ls-label" ariaLabel={`${l.name} weight`}
                           value={weight} spec={WEIGHT} onChange={(v, phase) => edit(i, { weight: v }, phase === "live")} />
              <NumberField testId={`ls-fade-${l.name}`} label="fade" labelClass="ls-label" slider={false}
                           value={typeof l.fade === "number" ? l.fade : 0.5} spec={FADE}
                           onChange={(v, phase) => edit(i, { fade: v }, phase === "live")}>
                <span className="ls-label">s</span>
              </NumberField>
            </div>
            <div className="ls-line">
              <MaskField layer={l.name} mask={l.mask} onChange={(mask) => edit(i, { mask }, false)} />
              <span className="ls-bar" title={st ? `live weight ${st.effective.toFixed(2)} (fade ${st.fade.toFixed(2)})` : "not running"}>
                <span data-testid={`ls-live-${l.name}`} data-effective={st ? st.effective.toFixed(3) : ""}
                      style={{ width: `${Math.round((st?.effective ?? 0) * 100)}%` }} />
              </span>
            </div>
          </div>
        );
      })}
      <AddLayer names={layers.map((l) => l.name)} onAdd={(name, mode) => onChange([...layers, { name, mode }], false)} />
    </div>
  );
}

/** A layer's DoF mask as text: names, globs (`head_*`) or dimensions (`stationary:*`), comma-separated;
 * applied on Enter or when the field is left (the server says which entry the robot lacks). */
function MaskField({ layer, mask, onChange }: { layer: string; mask: unknown; onChange: (mask: string[]) => void }) {
  const text = (Array.isArray(mask) ? mask.map(String) : ["*"]).join(", ");
  const [draft, setDraft] = useState<string | null>(null);
  const commit = () => {
    if (draft === null) return;
    const list = draft.split(",").map((x) => x.trim()).filter(Boolean);
    setDraft(null);
    if (list.join(", ") !== text) onChange(list.length ? list : ["*"]);
  };
  return (
    <input className="ls-mask" aria-label={`${layer} mask`} data-testid={`ls-mask-${layer}`} value={draft ?? text}
           title={`DoF mask (${maskSummary(mask)}): DoF names, globs like head_* or stationary:*, comma-separated`}
           onChange={(e) => setDraft(e.target.value)} onBlur={commit}
           onKeyDown={(e) => { if (e.key === "Enter") commit(); if (e.key === "Escape") setDraft(null); }} />
  );
}

/** A new layer on top of the stack: its name (a port name: letters, digits, _) and blend mode. */
function AddLayer({ names, onAdd }: { names: string[]; onAdd: (name: string, mode: string) => void }) {
  const [name, setName] = useState("");
  const [mode, setMode] = useState("additive");
  const clean = name.trim();
  const problem = !clean ? "" : !/^[A-Za-z_][A-Za-z0-9_]*$/.test(clean) ? "letters, digits and _ only"
    : names.includes(clean) ? "a layer has this name" : "";
  const add = () => { if (clean && !problem) { onAdd(clean, mode); setName(""); } };
  return (
    <div className="ls-add">
      <input placeholder="new layer name" aria-label="new layer name" data-testid="ls-new-name" value={name}
             onChange={(e) => setName(e.target.value)} onKeyDown={(e) => e.key === "Enter" && add()} />
      <select aria-label="new layer mode" value={mode} onChange={(e) => setMode(e.target.value)}>
        {MODES.map((m) => <option key={m} value={m}>{m}</option>)}
      </select>
      <button type="button" data-testid="ls-add" disabled={!clean || !!problem} onClick={add} title={problem || "add the layer on top"}>+ layer</button>
      {problem && <span className="ls-problem">{problem}</span>}
    </div>
  );
}
