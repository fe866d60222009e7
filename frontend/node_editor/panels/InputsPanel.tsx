// The running program's exposed inputs as controls: a slider per number, a box per flag, a top-view
// pad per 3D point (e.g. a gaze target).
import type { ExposedInput } from "../api";
import { NumberField } from "../fields/NumberField";
import type { NumberSpec } from "../fields/numberField";
import { useActions, useEditor } from "../store/EditorStore";

export function InputsPanel() {
  const { inputs } = useEditor().state;
  const { setInput } = useActions();
  return (
    <>
      {inputs.decls.map((d) => <InputControl key={d.name} decl={d} value={inputs.values[d.name]} onSet={(v) => setInput(d.name, v)} />)}
    </>
  );
}

type Vec3 = [number, number, number];

/** Top view of the space in front of the robot: x forward (0..1.2 m), y left (-0.8..0.8 m). */
function GazePad({ decl, value, onSet }: { decl: ExposedInput; value: unknown; onSet: (v: Vec3) => void }) {
  const v = (Array.isArray(value) ? value : decl.default ?? [1, 0, 0.3]) as Vec3;
  return (
    <div className="gaze-pad" title="drag to set the gaze target (top view: x forward, y left)"
         onMouseDown={(e) => {
           const box = (e.currentTarget as HTMLDivElement).getBoundingClientRect();
           const set = (ev: MouseEvent | React.MouseEvent) => {
             const x = 1.2 - ((ev.clientY - box.top) / box.height) * 1.2;
             const y = 0.8 - ((ev.clientX - box.left) / box.width) * 1.6;
             onSet([Math.round(x * 100) / 100, Math.round(y * 100) / 100, v[2]]);
           };
           set(e);
           const move = (ev: MouseEvent) => set(ev);
           const up = () => { window.removeEventListener("mousemove", move); window.removeEventListener("mouseup", up); };
           window.addEventListener("mousemove", move);
           window.addEventListener("mouseup", up);
         }}>
      <span className="pad-label">{decl.name}</span>
      <span className="pad-dot" style={{ top: `${(1 - v[0] / 1.2) * 100}%`, left: `${((0.8 - v[1]) / 1.6) * 100}%` }} />
    </div>
  );
}

/** A number input: the slider spans its declared range with a step that divides it exactly (../fields
 * keeps the thumb under the hand while it is held), the text box takes any value in that range. */
function InputNumber({ decl, value, onSet }: { decl: ExposedInput; value: unknown; onSet: (v: number) => void }) {
  const min = decl.min ?? -1, max = decl.max ?? 1;
  const integer = decl.type === "int";
  const spec: NumberSpec = { softMin: min, softMax: max, hardMin: decl.min ?? undefined, hardMax: decl.max ?? undefined,
                             step: integer ? 1 : (max - min) / 200, integer };
  const stored = Number(value ?? decl.default ?? 0);
  return (
    <div className="input-slider">
      <NumberField testId={`input-${decl.name}`} label={decl.name} labelClass="input-name" ariaLabel={`input ${decl.name}`}
                   value={Number.isFinite(stored) ? stored : 0} spec={spec} onChange={(v) => onSet(v)} />
    </div>
  );
}

function InputControl({ decl, value, onSet }: { decl: ExposedInput; value: unknown; onSet: (v: unknown) => void }) {
  if (decl.type === "vec3") return <GazePad decl={decl} value={value} onSet={onSet} />;
  if (decl.type === "float" || decl.type === "int") return <InputNumber decl={decl} value={value} onSet={onSet} />;
  if (decl.type === "bool") return <label><input type="checkbox" checked={Boolean(value)} onChange={(e) => onSet(e.target.checked)} /> {decl.name}</label>;
  return null;
}
