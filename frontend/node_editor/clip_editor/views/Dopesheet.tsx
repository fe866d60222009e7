// The dopesheet: one row per DoF (grouped, collapsible; DoFs without a track greyed so keys can be
// inserted for them), keys as diamonds on the shared time axis, and the marker row above. Click/box
// select, drag to move (frame snap; Ctrl snaps to keys, Alt none), and Blender's keys: G grab, S scale
// about the playhead, I/K insert, X/Delete, Ctrl+C/V, A / Alt+A, Home. Edits go out through onChange
// (transient while dragging, one commit on release); the document is never owned here.
import { memo, useCallback, useLayoutEffect, useMemo, useRef, useState } from "react";
import type { KeyboardEvent as ReactKeyboardEvent, PointerEvent as ReactPointerEvent } from "react";
import { moveDelta, moveKeys, scaleKeys } from "../model/edits";
import type { Clip, ClipErrors, DofInfo, KeyRef } from "../model/types";
import { keyId } from "../model/types";
import type { Box, LayoutRow } from "./dopesheetLayout";
import { keysInBox, layoutHeight, layoutRows, ROW_H, summaryTimes, unionRefs, visibleKeys } from "./dopesheetLayout";
import { snapOptions, trackPointer, typingInto, useElementWidth, useWheel, wheelTimeView } from "./interaction";
import type { ModalCompute, OnChange } from "./keyOps";
import { keyCommand, letterOf, modalKey, useModal } from "./keyOps";
import { pressKey } from "./keyDrag";
import { MarkerRow } from "./MarkerRow";
import type { TimeView } from "./timeView";
import { frameAll, GUTTER, panBy, secondsPerPx, timeToX } from "./timeView";
import "./views.css";

export interface DopesheetProps {
  doc: Clip;
  rows: { group: string; dofs: DofInfo[] }[];
  view: TimeView;
  setView: (view: TimeView) => void;
  playhead: number;
  setPlayhead: (t: number) => void;
  selection: KeyRef[];
  setSelection: (sel: KeyRef[]) => void;
  onChange: OnChange;
  selectedDofs: string[];
  setSelectedDofs: (dofs: string[]) => void;
  fps: number;
  errors: ClipErrors;
}

const DIAMOND = `M0 -6 L6 0 L0 6 L-6 0 Z`;
const SMALL_DIAMOND = `M0 -4 L4 0 L0 4 L-4 0 Z`;

function DopesheetImpl(p: DopesheetProps) {
  const { doc, rows, view, setView, playhead, selection, setSelection, onChange, selectedDofs, setSelectedDofs, fps, errors } = p;
  const root = useRef<HTMLDivElement>(null);
  const keysSvg = useRef<SVGSVGElement>(null);
  const total = useElementWidth(root);
  const width = Math.max(1, total - GUTTER);
  const [collapsed, setCollapsed] = useState<ReadonlySet<string>>(() => new Set());
  const [box, setBox] = useState<Box | null>(null);

  const layout = useMemo(() => layoutRows(doc, rows, collapsed), [doc, rows, collapsed]);
  const height = layoutHeight(layout);
  const selected = useMemo(() => new Set(selection.map(keyId)), [selection]);
  // per track, its selected key indices as a string: a memoised track re-renders only when its own change
  const selectedByDof = useMemo(() => {
    const m = new Map<string, number[]>();
    for (const r of selection) m.set(r.dof, [...(m.get(r.dof) ?? []), r.index]);
    return new Map([...m].map(([d, ix]) => [d, ix.sort((a, b) => a - b).join(",")]));
  }, [selection]);
  const spp = secondsPerPx(view, width);

  const compute: ModalCompute = useCallback(
    (m, x, _y, mods) => {
      const opts = snapOptions(mods, fps, spp, playhead);
      if (m.kind === "grab") {
        const dt = moveDelta(m.doc, m.sel, (x - m.x0) * spp, opts);
        return { edited: moveKeys(m.doc, m.sel, dt, 0, { ...opts, snap: opts.snap === "keys" ? "none" : opts.snap }), hint: `Grab: Δt ${dt.toFixed(3)} s` };
      }
      const left = keysSvg.current?.getBoundingClientRect().left ?? 0;
      const pivot = left + timeToX(view, width, playhead);
      const d0 = m.x0 - pivot;
      const factor = (x - pivot) / (Math.abs(d0) < 2 ? (d0 < 0 ? -2 : 2) : d0);
      return {
        edited: scaleKeys(m.doc, m.sel, playhead, factor, opts),
        hint: `Scale: ×${factor.toFixed(3)} about ${playhead.toFixed(3)} s`,
      };
    },
    [fps, spp, view, width, playhead],
  );
  const modal = useModal(onChange, compute);

  useWheel(root, (e) => {
    const rect = keysSvg.current?.getBoundingClientRect();
    if (!rect) return;
    e.preventDefault();
    setView(wheelTimeView(view, width, e.clientX - rect.left, e));
  });

  const pan = (e: ReactPointerEvent) => {
    const start = view;
    trackPointer(e, (m) => setView(panBy(start, -(m.clientX - e.clientX) * spp)), () => {});
  };

  const onKeyPointerDown = (e: ReactPointerEvent, ref: KeyRef) => {
    if (e.button !== 0) return;
    root.current?.focus();
    pressKey(e, ref, {
      doc, selection, selected, setSelection, onChange,
      move: (start, sel, down, m) => moveKeys(start, sel, (m.clientX - down.clientX) * spp, 0, snapOptions(m, fps, spp, playhead)),
    });
  };

  // a stable handler for the memoised tracks, always running the latest closure
  const keyDownLatest = useRef(onKeyPointerDown);
  useLayoutEffect(() => {
    keyDownLatest.current = onKeyPointerDown;
  });
  const keyDown = useCallback((e: ReactPointerEvent, ref: KeyRef) => keyDownLatest.current(e, ref), []);

  const onAreaPointerDown = (e: ReactPointerEvent<SVGSVGElement>) => {
    root.current?.focus();
    if (e.button === 1 || (e.button === 0 && e.altKey)) {
      e.preventDefault();
      pan(e);
      return;
    }
    if (e.button !== 0) return;
    e.preventDefault();
    const rect = e.currentTarget.getBoundingClientRect();
    const x0 = e.clientX - rect.left;
    const y0 = e.clientY - rect.top;
    const startView = view;
    const additive = e.shiftKey;
    const base = selection;
    trackPointer(
      e,
      (m) => setBox({ x0, y0, x1: m.clientX - rect.left, y1: m.clientY - rect.top }),
      (u, moved) => {
        setBox(null);
        if (!moved) {
          if (!additive) setSelection([]);
          return;
        }
        const hit = keysInBox(doc, layout, startView, width, { x0, y0, x1: u.clientX - rect.left, y1: u.clientY - rect.top });
        setSelection(additive ? unionRefs(base, hit) : hit);
      },
    );
  };

  const infoOf = useMemo(() => new Map(rows.flatMap((g) => g.dofs.map((d) => [d.name, d] as const))), [rows]);
  const insertDofs = (selectedDofs.length ? selectedDofs : [...new Set(selection.map((r) => r.dof))]).map((d) => infoOf.get(d) ?? d);
  const onKeyDown = (e: ReactKeyboardEvent) => {
    if (typingInto(e.target)) return;
    if (modalKey(e, modal)) {
      e.preventDefault();
      return;
    }
    const k = letterOf(e);
    const plain = !e.ctrlKey && !e.metaKey && !e.altKey;
    if ((k === "g" || k === "s") && plain) {
      e.preventDefault();
      if (selection.length)
        modal.start({ kind: k === "g" ? "grab" : "scale", x0: modal.pointer.current.x, y0: modal.pointer.current.y, doc, sel: selection });
      return;
    }
    const handled = keyCommand(e, {
      doc, selection, setSelection, onChange, playhead, insertDofs,
      pasteTargets: selectedDofs,
      robotDofs: infoOf.size ? [...infoOf.values()] : undefined,
      allKeys: () => visibleKeys(doc, layout),
      frame: () => setView(frameAll(doc)),
    });
    if (handled) e.preventDefault();
  };


  const pickDof = (e: React.MouseEvent, dof: string) => {
    root.current?.focus();
    if (e.shiftKey || e.ctrlKey || e.metaKey)
      setSelectedDofs(selectedDofs.includes(dof) ? selectedDofs.filter((d) => d !== dof) : [...selectedDofs, dof]);
    else setSelectedDofs([dof]);
  };
  const toggleGroup = (g: string) => {
    const next = new Set(collapsed);
    if (next.has(g)) next.delete(g);
    else next.add(g);
    setCollapsed(next);
  };

  const px = timeToX(view, width, playhead);
  return (
    <div ref={root} className="dopesheet" data-testid="dopesheet" tabIndex={0} onKeyDown={onKeyDown}
         onPointerMove={modal.onPointerMove} onPointerDownCapture={modal.onPointerDownCapture}
         onContextMenu={(e) => e.preventDefault()}>
      <div className="view-hint" data-testid="dopesheet-hint">{modal.hint ?? ""}</div>
      <MarkerRow doc={doc} view={view} width={width} fps={fps} selection={selection} onChange={onChange} />
      <div className="ds-body">
        <div className="ds-names" style={{ width: GUTTER, height }}>
          {layout.map((r) => (r.kind === "group" ? (
            <div key={`g-${r.group}`} className="ds-group" data-testid={`group-${r.group}`}
                 style={{ top: r.y, height: ROW_H }} onClick={() => toggleGroup(r.group)}>
              {r.collapsed ? "▸" : "▾"} {r.group} <span className="ds-count">{r.count}</span>
            </div>
          ) : (
            <NameRow key={`d-${r.dof}`} row={r} selected={selectedDofs.includes(r.dof)} error={errors[r.dof]} onPick={pickDof} />
          )))}
        </div>
        <svg ref={keysSvg} className="ds-keys" width={width} height={Math.max(height, 1)} onPointerDown={onAreaPointerDown}>
          {layout.map((r) => (
            <rect key={r.kind === "group" ? `gb-${r.group}` : `rb-${r.dof}`} x={0} y={r.y} width={width} height={ROW_H}
                  className={r.kind === "group" ? "ds-row-group" : r.hasTrack ? "ds-row" : "ds-row empty"} />
          ))}
          {layout.map((r) => (r.kind === "group" && r.collapsed ? (
            <g key={`s-${r.group}`} className="ds-summary">
              {summaryTimes(doc, r.dofs).map((t) => (
                <path key={t} d={SMALL_DIAMOND} transform={`translate(${timeToX(view, width, t)},${r.y + ROW_H / 2})`} />
              ))}
            </g>
          ) : null))}
          {layout.map((r) => (r.kind === "dof" ? (
            <TrackKeys key={`k-${r.dof}`} row={r} keys={doc.tracks[r.dof]} view={view} width={width}
                       selected={selectedByDof.get(r.dof) ?? ""} errors={errors} onKeyDown={keyDown} />
          ) : null))}
          {px >= 0 && px <= width && <line className="playhead-line" x1={px} x2={px} y1={0} y2={height} />}
          {box && <rect className="box-select" x={Math.min(box.x0, box.x1)} y={Math.min(box.y0, box.y1)}
                        width={Math.abs(box.x1 - box.x0)} height={Math.abs(box.y1 - box.y0)} />}
        </svg>
      </div>
    </div>
  );
}

function NameRow({ row, selected, error, onPick }: {
  row: Extract<LayoutRow, { kind: "dof" }>;
  selected: boolean;
  error: string | undefined;
  onPick: (e: React.MouseEvent, dof: string) => void;
}) {
  const cls = ["ds-name", row.hasTrack ? "" : "no-track", selected ? "selected" : "", error ? "has-error" : ""].filter(Boolean).join(" ");
  const title = error ?? (row.info?.description ? `${row.dof}: ${row.info.description}` : row.dof);
  return (
    <div className={cls} data-testid={`track-${row.dof}`} title={title} style={{ top: row.y, height: ROW_H }}
         onClick={(e) => onPick(e, row.dof)}>
      {row.dof}
    </div>
  );
}

/** One track's diamonds; memoised so a drag re-renders only the tracks whose keys changed. */
const TrackKeys = memo(function TrackKeys({ row, keys, view, width, selected, errors, onKeyDown }: {
  row: Extract<LayoutRow, { kind: "dof" }>;
  keys: Clip["tracks"][string] | undefined;
  view: TimeView;
  width: number;
  /** the track's selected key indices, comma-separated */
  selected: string;
  errors: ClipErrors;
  onKeyDown: (e: ReactPointerEvent, ref: KeyRef) => void;
}) {
  if (!keys) return null;
  const sels = new Set(selected ? selected.split(",").map(Number) : []);
  const cy = row.y + ROW_H / 2;
  return (
    <g className="ds-track">
      {keys.map((k, i) => {
        const x = timeToX(view, width, k.t);
        if (x < -8 || x > width + 8) return null;
        const id = `${row.dof}#${i}`;
        const sel = sels.has(i);
        const err = errors[id];
        return (
          <path key={i} d={DIAMOND} transform={`translate(${x},${cy})`}
                className={`ds-key${sel ? " selected" : ""}${err ? " key-error" : ""}${k.interp === "constant" ? " hold" : ""}`}
                data-testid={`key-${row.dof}-${i}`} data-t={k.t} data-selected={sel ? "true" : "false"}
                onPointerDown={(e) => onKeyDown(e, { dof: row.dof, index: i })}>
            <title>{err ?? `${row.dof} @ ${k.t.toFixed(3)} s = ${typeof k.v === "number" ? k.v.toFixed(4) : JSON.stringify(k.v)}`}</title>
          </path>
        );
      })}
    </g>
  );
});

export const Dopesheet = memo(DopesheetImpl);
export default Dopesheet;
