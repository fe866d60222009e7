// The graph editor: the selected continuous DoFs' curves (what the engine evaluates, plus the relative
// clip's rest offsets), their limits, keys and the selected bezier keys' handles, the trajectory
// helper's over-limit spans and the ghost. Drag keys (time and value) or handles; click/box select; G
// grab, S scale about the playhead, X/Delete, I/K, Home frames time and values, T/V menus, Ctrl+wheel
// zooms values. Edits go out through onChange (transient while dragging, one commit on release).
import { memo, useCallback, useLayoutEffect, useMemo, useRef, useState } from "react";
import type { KeyboardEvent as ReactKeyboardEvent, PointerEvent as ReactPointerEvent } from "react";
import type { FilteredTracks, TrackAnalysis } from "../../generated/api";
import { dragHandle, moveDelta, moveKeys, scaleKeys, setKeyProps } from "../model/edits";
import type { Clip, ClipErrors, DofInfo, Edited, KeyRef, Side } from "../model/types";
import { DEFAULT_FPS, keyId } from "../model/types";
import { unionRefs } from "./dopesheetLayout";
import type { ValueView } from "./graphDraw";
import { curveColour, valueToY, yToValue, zoomValues } from "./graphDraw";
import { Axis, CurveLayer, KeyLayer, toPlot } from "./GraphLayers";
import type { PlotProps } from "./GraphLayers";
import { GraphMenu, GraphToolbar } from "./GraphToolbar";
import type { KeyProps, MenuState } from "./GraphToolbar";
import { snapOptions, trackPointer, typingInto, useElementSize, useWheel, wheelTimeView } from "./interaction";
import type { ModalCompute, OnChange } from "./keyOps";
import { keyCommand, letterOf, modalKey, useModal } from "./keyOps";
import { graphFrame } from "./graphFrame";
import { pressKey } from "./keyDrag";
import type { TimeView } from "./timeView";
import { GUTTER, panBy, secondsPerPx, timeToX } from "./timeView";
import "./views.css";

export interface GraphEditorProps {
  doc: Clip;
  /** the DoFs whose curves show (only continuous ones are drawn) */
  dofs: DofInfo[];
  view: TimeView;
  setView: (view: TimeView) => void;
  playhead: number;
  setPlayhead: (t: number) => void;
  selection: KeyRef[];
  setSelection: (sel: KeyRef[]) => void;
  onChange: OnChange;
  /** added to stored values for display (a relative clip's rest values) */
  offsets: Record<string, number>;
  helper: TrackAnalysis | null;
  ghost: FilteredTracks | null;
  errors: ClipErrors;
  /** frame rate keys snap to (default: the clip's fps, else 30) */
  fps?: number;
}

function GraphEditorImpl(p: GraphEditorProps) {
  const { doc, view, setView, playhead, selection, setSelection, onChange, offsets, helper, ghost, errors } = p;
  const fps = p.fps ?? doc.fps ?? DEFAULT_FPS;
  const root = useRef<HTMLDivElement>(null);
  const area = useRef<HTMLDivElement>(null);
  const svg = useRef<SVGSVGElement>(null);
  const size = useElementSize(area);
  const width = Math.max(1, size.width - GUTTER);
  const height = Math.max(40, size.height);
  const [box, setBox] = useState<{ x0: number; y0: number; x1: number; y1: number } | null>(null);
  const [menu, setMenu] = useState<MenuState | null>(null);

  const shown = useMemo(() => p.dofs.filter((d) => d.type === "continuous"), [p.dofs]);
  const dofKey = shown.map((d) => d.name).join("|");
  const [vv, setVv] = useState<{ key: string; v: ValueView } | null>(null);
  const frozen = vv && vv.key === dofKey ? vv.v : null;
  // auto-framed only until the user works in the graph: no sampling per drag step once frozen
  const auto = useMemo(() => (frozen ? null : graphFrame(doc, shown, offsets, ghost).values), [frozen, doc, shown, offsets, ghost]);
  const values = frozen ?? auto ?? { v0: -1, v1: 1 };
  /** keep the value view still once the user works in the graph (auto framing would jump mid-drag) */
  const freeze = (v: ValueView = values) => setVv({ key: dofKey, v });

  const plot: PlotProps = useMemo(
    () => ({ t0: view.t0, t1: view.t1, v0: values.v0, v1: values.v1, width, height }),
    [view.t0, view.t1, values.v0, values.v1, width, height],
  );
  const spp = secondsPerPx(view, width);
  const vpp = (values.v1 - values.v0) / height;

  const selectedByDof = useMemo(() => {
    const m = new Map<string, number[]>();
    for (const r of selection) m.set(r.dof, [...(m.get(r.dof) ?? []), r.index]);
    return new Map([...m].map(([d, ix]) => [d, ix.sort((a, b) => a - b).join(",")]));
  }, [selection]);
  const shownKeys = useCallback((): KeyRef[] => shown.flatMap((d) => (doc.tracks[d.name] ?? []).map((_k, index) => ({ dof: d.name, index }))), [shown, doc]);
  const selected = useMemo(() => new Set(selection.map(keyId)), [selection]);

  const compute: ModalCompute = useCallback(
    (m, x, y, mods) => {
      const opts = snapOptions(mods, fps, spp, playhead);
      if (m.kind === "grab") {
        const dt = moveDelta(m.doc, m.sel, (x - m.x0) * spp, opts);
        const dv = -(y - m.y0) * vpp;
        return { edited: moveKeys(m.doc, m.sel, dt, dv, { ...opts, snap: opts.snap === "keys" ? "none" : opts.snap }), hint: `Grab: Δt ${dt.toFixed(3)} s, Δv ${dv.toFixed(4)}` };
      }
      const left = (svg.current?.getBoundingClientRect().left ?? 0) + GUTTER;
      const pivot = left + timeToX(view, width, playhead);
      const d0 = m.x0 - pivot;
      const factor = (x - pivot) / (Math.abs(d0) < 2 ? (d0 < 0 ? -2 : 2) : d0);
      return { edited: scaleKeys(m.doc, m.sel, playhead, factor, opts), hint: `Scale: ×${factor.toFixed(3)} about ${playhead.toFixed(3)} s` };
    },
    [fps, spp, vpp, view, width, playhead],
  );
  const modal = useModal(onChange, compute);

  useWheel(area, (e) => {
    const rect = svg.current?.getBoundingClientRect();
    if (!rect) return;
    e.preventDefault();
    if (e.ctrlKey || e.metaKey) {
      const v = yToValue(toPlot(plot), e.clientY - rect.top);
      freeze(zoomValues(values, v, Math.exp(e.deltaY * 0.0015)));
    } else setView(wheelTimeView(view, width, e.clientX - rect.left - GUTTER, e));
  });

  const onKeyPointerDown = (e: ReactPointerEvent, ref: KeyRef) => {
    if (e.button !== 0) return;
    root.current?.focus();
    freeze();
    pressKey(e, ref, {
      doc, selection, selected, setSelection, onChange,
      move: (start, sel, down, m) => moveKeys(start, sel, (m.clientX - down.clientX) * spp,
        -(m.clientY - down.clientY) * vpp, snapOptions(m, fps, spp, playhead)),
    });
  };

  const onHandlePointerDown = (e: ReactPointerEvent, ref: KeyRef, side: Side) => {
    if (e.button !== 0) return;
    e.stopPropagation();
    e.preventDefault();
    root.current?.focus();
    freeze();
    const rect = svg.current?.getBoundingClientRect();
    if (!rect) return;
    const startDoc = doc;
    const pl = toPlot(plot);
    const off = offsets[ref.dof] ?? 0;
    let last: Edited | null = null;
    trackPointer(
      e,
      (m) => {
        const t = pl.view.t0 + (m.clientX - rect.left - GUTTER) * spp;
        const v = yToValue(pl, m.clientY - rect.top) - off;
        last = dragHandle(startDoc, ref, side, [t, v], selection);
        onChange(last, null);
      },
      (_u, moved) => {
        if (moved && last) onChange(last, { label: "Move handle" });
      },
    );
  };

  // stable handlers for the memoised key layers, always running the latest closures
  const latest = useRef({ key: onKeyPointerDown, handle: onHandlePointerDown });
  useLayoutEffect(() => {
    latest.current = { key: onKeyPointerDown, handle: onHandlePointerDown };
  });
  const onKey = useCallback((e: ReactPointerEvent, ref: KeyRef) => latest.current.key(e, ref), []);
  const onHandle = useCallback((e: ReactPointerEvent, ref: KeyRef, side: Side) => latest.current.handle(e, ref, side), []);

  const onAreaPointerDown = (e: ReactPointerEvent<SVGSVGElement>) => {
    root.current?.focus();
    setMenu(null);
    const rect = e.currentTarget.getBoundingClientRect();
    if (e.button === 1 || (e.button === 0 && e.altKey)) {
      e.preventDefault();
      const sv = view;
      const vals = values;
      trackPointer(e, (m) => {
        setView(panBy(sv, -(m.clientX - e.clientX) * spp));
        const dv = (m.clientY - e.clientY) * vpp;
        freeze({ v0: vals.v0 + dv, v1: vals.v1 + dv });
      }, () => {});
      return;
    }
    if (e.button !== 0) return;
    e.preventDefault();
    const x0 = e.clientX - rect.left - GUTTER;
    const y0 = e.clientY - rect.top;
    const additive = e.shiftKey;
    const base = selection;
    const pl = toPlot(plot);
    trackPointer(
      e,
      (m) => setBox({ x0, y0, x1: m.clientX - rect.left - GUTTER, y1: m.clientY - rect.top }),
      (u, moved) => {
        setBox(null);
        if (!moved) {
          if (!additive) setSelection([]);
          return;
        }
        const x1 = u.clientX - rect.left - GUTTER;
        const y1 = u.clientY - rect.top;
        const [xa, xb] = [Math.min(x0, x1), Math.max(x0, x1)];
        const [ya, yb] = [Math.min(y0, y1), Math.max(y0, y1)];
        const hit: KeyRef[] = [];
        for (const d of shown) {
          const off = offsets[d.name] ?? 0;
          (doc.tracks[d.name] ?? []).forEach((k, index) => {
            if (typeof k.v !== "number") return;
            const kx = timeToX(pl.view, pl.width, k.t);
            const ky = valueToY(pl, k.v + off);
            if (kx >= xa && kx <= xb && ky >= ya && ky <= yb) hit.push({ dof: d.name, index });
          });
        }
        setSelection(additive ? unionRefs(base, hit) : hit);
      },
    );
  };

  const apply = (props: KeyProps, label: string) => {
    if (selection.length) onChange(setKeyProps(doc, selection, props), { label });
  };

  const frame = () => {
    const f = graphFrame(doc, shown, offsets, ghost);
    setView(f.view);
    freeze(f.values);
  };

  const onKeyDown = (e: ReactKeyboardEvent) => {
    if (typingInto(e.target)) return;
    if (menu && e.key === "Escape") {
      setMenu(null);
      e.preventDefault();
      return;
    }
    if (modalKey(e, modal)) {
      e.preventDefault();
      return;
    }
    const k = letterOf(e);
    const plain = !e.ctrlKey && !e.metaKey && !e.altKey;
    const rect = root.current?.getBoundingClientRect();
    if ((k === "g" || k === "s") && plain) {
      e.preventDefault();
      if (selection.length) {
        freeze();
        modal.start({ kind: k === "g" ? "grab" : "scale", x0: modal.pointer.current.x, y0: modal.pointer.current.y, doc, sel: selection });
      }
      return;
    }
    if ((k === "t" || k === "v") && plain) {
      e.preventDefault();
      if (selection.length && rect)
        setMenu({ kind: k === "t" ? "interp" : "handle", x: Math.max(0, modal.pointer.current.x - rect.left), y: Math.max(0, modal.pointer.current.y - rect.top) });
      return;
    }
    if (k !== "Home") freeze();
    const names = shown.map((d) => d.name);
    if (keyCommand(e, { doc, selection, setSelection, onChange, playhead, insertDofs: shown, pasteTargets: names, allKeys: shownKeys, frame }))
      e.preventDefault();
  };


  const byDof = useMemo(() => {
    const m = new Map<string, NonNullable<typeof helper>["ranges"]>();
    for (const r of helper?.ranges ?? []) m.set(r.dof, [...(m.get(r.dof) ?? []), r]);
    return m;
  }, [helper]);
  const legend = shown.map((d, i) => ({ dof: d.name, colour: curveColour(i) }));
  const px = timeToX(view, width, playhead);

  return (
    <div ref={root} className="graph-editor" data-testid="graph-editor" tabIndex={0} onKeyDown={onKeyDown}
         onPointerMove={modal.onPointerMove} onPointerDownCapture={modal.onPointerDownCapture} onContextMenu={(e) => e.preventDefault()}>
      <GraphToolbar doc={doc} selection={selection} apply={apply} legend={legend} helper={helper} ghost={ghost} />
      <div className="view-hint" data-testid="graph-hint">{modal.hint ?? (shown.length ? "" : "Select DoFs in the dopesheet to see their curves")}</div>
      <div ref={area} className="graph-area">
        <svg ref={svg} width={size.width} height={height} onPointerDown={onAreaPointerDown}>
          <Axis plot={plot} gutter={GUTTER} />
          <svg x={GUTTER} y={0} width={width} height={height} overflow="hidden">
            {shown.map((d, i) => (
              <CurveLayer key={d.name} dof={d.name} keys={doc.tracks[d.name]} colour={curveColour(i)} offset={offsets[d.name] ?? 0}
                          min={d.min} max={d.max} plot={plot} ranges={byDof.get(d.name)} rangeColours={helper?.colours}
                          ghost={ghost?.tracks[d.name]} ghostRate={ghost?.rate ?? 0} />
            ))}
            {px >= 0 && px <= width && <line className="playhead-line" x1={px} x2={px} y1={0} y2={height} />}
            {shown.map((d, i) => (
              <KeyLayer key={d.name} dof={d.name} keys={doc.tracks[d.name]} colour={curveColour(i)} offset={offsets[d.name] ?? 0}
                        plot={plot} selected={selectedByDof.get(d.name) ?? ""} errors={errors} onKey={onKey} onHandle={onHandle} />
            ))}
            {box && <rect className="box-select" x={Math.min(box.x0, box.x1)} y={Math.min(box.y0, box.y1)}
                          width={Math.abs(box.x1 - box.x0)} height={Math.abs(box.y1 - box.y0)} />}
          </svg>
        </svg>
        {menu && <GraphMenu menu={menu} apply={apply} close={() => setMenu(null)} />}
      </div>
    </div>
  );
}

export const GraphEditor = memo(GraphEditorImpl);
export default GraphEditor;
