// The marker row above the dopesheet's tracks: the clip's anchors (flags with their names) and events
// (speech with its text, sounds with the clip name) at their times. Dragging one moves it (one undo step
// on release); a double-click on empty row space asks a name inline and adds an anchor there; a
// right-click on a marker removes it.
import { memo, useRef, useState } from "react";
import type { PointerEvent as ReactPointerEvent } from "react";
import { addAnchor, moveMarker, removeMarker } from "../model/edits";
import type { Clip, ClipEvent, Edited, KeyRef, MarkerRef } from "../model/types";
import { trackPointer } from "./interaction";
import type { OnChange } from "./keyOps";
import type { TimeView } from "./timeView";
import { GUTTER, secondsPerPx, snapFrame, timeToX, xToTime } from "./timeView";

export interface MarkerRowProps {
  doc: Clip;
  view: TimeView;
  /** width (px) of the time area (right of the gutter) */
  width: number;
  fps: number;
  selection: KeyRef[];
  onChange: OnChange;
  gutter?: number;
}

export const MARKER_ROW_HEIGHT = 26;

/** A short label for an event: what is said, the sound's clip name, else its kind. */
export function eventLabel(e: ClipEvent): string {
  const p = e.payload ?? {};
  const text = typeof p.text === "string" ? p.text : typeof p.clip === "string" ? p.clip : typeof p.name === "string" ? p.name : "";
  const icon = e.kind === "say" ? "💬" : e.kind === "sound" ? "🔊" : "•";
  const body = text ? (text.length > 24 ? `${text.slice(0, 23)}…` : text) : e.kind;
  return `${icon} ${body}`;
}

/** A marker edit's result as an Edited (the selection of keys is untouched by marker edits). */
function asEdited(r: Clip | Edited, selection: KeyRef[]): Edited {
  return "doc" in r ? r : { doc: r, selection };
}

function MarkerRowImpl({ doc, view, width, fps, selection, onChange, gutter = GUTTER }: MarkerRowProps) {
  const svg = useRef<SVGSVGElement>(null);
  const [naming, setNaming] = useState<{ t: number; x: number } | null>(null);
  const x = (t: number) => timeToX(view, width, t);

  const dragMarker = (e: ReactPointerEvent, ref: MarkerRef, t0: number) => {
    if (e.button !== 0) return;
    e.stopPropagation();
    e.preventDefault();
    const start = doc;
    const spp = secondsPerPx(view, width);
    let last: Edited | null = null;
    trackPointer(
      e,
      (m) => {
        const raw = Math.max(0, t0 + (m.clientX - e.clientX) * spp);
        last = asEdited(moveMarker(start, ref, m.altKey ? raw : snapFrame(raw, fps)), selection);
        if (last) onChange(last, null);
      },
      (_u, moved) => {
        if (moved && last) onChange(last, { label: "Move marker" });
      },
    );
  };

  const remove = (e: { preventDefault: () => void; stopPropagation: () => void }, ref: MarkerRef) => {
    e.preventDefault();
    e.stopPropagation();
    onChange(asEdited(removeMarker(doc, ref), selection), { label: "Remove marker" });
  };

  const onDoubleClick = (e: React.MouseEvent) => {
    if (e.target !== svg.current && !(e.target as Element).classList.contains("marker-bg")) return;
    const rect = svg.current?.getBoundingClientRect();
    if (!rect) return;
    const px = e.clientX - rect.left;
    setNaming({ t: snapFrame(xToTime(view, width, px), fps), x: px });
  };

  const submit = (name: string) => {
    const n = name.trim();
    const at = naming;
    setNaming(null);
    if (!n || !at) return;
    onChange(asEdited(addAnchor(doc, n, at.t), selection), { label: "Add anchor" });
  };

  const anchors = Object.entries(doc.anchors ?? {});
  const events = doc.events ?? [];
  const h = MARKER_ROW_HEIGHT;
  return (
    <div className="marker-row" style={{ height: h }}>
      <div className="marker-gutter" style={{ width: gutter }} title="Anchors and events; double-click the row to add an anchor">
        Markers
      </div>
      <div className="marker-area">
        <svg ref={svg} width={width} height={h} onDoubleClick={onDoubleClick} className="marker-svg">
          <rect className="marker-bg" x={0} y={0} width={width} height={h} />
          {events.map((ev, i) => {
            const ex = x(ev.t);
            if (ex < -200 || ex > width + 10) return null;
            const label = eventLabel(ev);
            return (
              <g key={`e${i}`} className="marker event" data-testid={`event-${i}`} data-t={ev.t}
                 transform={`translate(${ex},0)`}
                 onPointerDown={(e) => dragMarker(e, { kind: "event", index: i }, ev.t)}
                 onContextMenu={(e) => remove(e, { kind: "event", index: i })}>
                <title>{`${ev.kind} on ${ev.dof} at ${ev.t.toFixed(3)} s: ${label} — drag to move, right-click to remove`}</title>
                <rect x={-1} y={h / 2} width={2} height={h / 2} />
                <text x={3} y={h - 4}>{label}</text>
              </g>
            );
          })}
          {anchors.map(([name, t]) => {
            const ax = x(t);
            if (ax < -200 || ax > width + 10) return null;
            return (
              <g key={`a${name}`} className="marker anchor" data-testid={`anchor-${name}`} data-t={t}
                 transform={`translate(${ax},0)`}
                 onPointerDown={(e) => dragMarker(e, { kind: "anchor", name }, t)}
                 onContextMenu={(e) => remove(e, { kind: "anchor", name })}>
                <title>{`anchor ${name} at ${t.toFixed(3)} s — drag to move, right-click to remove`}</title>
                <path d="M0 2 L5 7 L0 12 L-5 7 Z" />
                <line x1={0} x2={0} y1={12} y2={h} />
                <text x={7} y={11}>{name}</text>
              </g>
            );
          })}
        </svg>
        {naming && (
          <input className="anchor-name-input" data-testid="anchor-name-input" autoFocus placeholder="anchor name"
                 style={{ left: Math.max(0, Math.min(width - 120, naming.x)) }}
                 onKeyDown={(e) => {
                   e.stopPropagation();
                   if (e.key === "Enter") submit(e.currentTarget.value);
                   else if (e.key === "Escape") setNaming(null);
                 }}
                 onBlur={() => setNaming(null)} />
        )}
      </div>
    </div>
  );
}

export const MarkerRow = memo(MarkerRowImpl);
export default MarkerRow;
