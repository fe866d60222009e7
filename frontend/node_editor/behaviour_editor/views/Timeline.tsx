// The behaviour timeline: the clip editor's Ruler over one lane per track, each item a bar over its
// planned span (from the server's plan), links from relative items to what they are timed from, and the
// playhead through every lane. Dragging a bar retimes it (live preview; snapping to other items' starts,
// ends and anchors within 8 px unless Alt; the change is reported once, on release), dragging it onto
// another lane moves it there, Escape drops the drag, a click selects. Wheel zooms, Shift+wheel or a
// middle-drag pans.
import { useRef, useState } from "react";
import type { PointerEvent as ReactPointerEvent } from "react";
import { Ruler } from "../../clip_editor/views/Ruler";
import { trackPointer, useElementWidth, useWheel, wheelTimeView } from "../../clip_editor/views/interaction";
import type { TimeView } from "../../clip_editor/views/timeView";
import { GUTTER, panBy, secondsPerPx } from "../../clip_editor/views/timeView";
import { allItems, dependentsOf, plannedById, refMoment } from "../model/refs";
import { snapTargets } from "../model/snap";
import type { BehaviourDoc, Issue, Plan, PlannedItem, SnapTarget } from "../model/types";
import { isStartRef } from "../model/types";
import type { DragState } from "./drag";
import { dragTo, shownAnchors, shownSpan } from "./drag";
import { ItemBar } from "./ItemBar";
import type { Link } from "./layout";
import { LANE_HEIGHT, laneAt, laneTop, linkFor } from "./layout";
import { TimelineOverlay } from "./TimelineOverlay";
import "./timeline.css";

export interface TimelineProps {
  doc: BehaviourDoc;
  /** the last plan (POST /api/behaviours/plan) of `doc`; null before the first arrives */
  plan: Plan | null;
  view: TimeView;
  setView: (view: TimeView) => void;
  playhead: number;
  setPlayhead: (t: number) => void;
  selected: string | null;
  select: (id: string | null) => void;
  /** a bar was dragged: its new start (s), and the item moment it snapped to, if any */
  onRetime: (id: string, start: number, snap: SnapTarget | null) => void;
  /** a bar was dragged onto another lane (called after onRetime when both changed) */
  onMoveTrack?: (id: string, trackIndex: number) => void;
  errorsByItem: Map<string, Issue[]>;
  fps?: number;
  /** total width (px) incl. the gutter; measured when omitted */
  width?: number;
}

const NO_ANCHORS: Record<string, number> = {};

export function Timeline({
  doc, plan, view, setView, playhead, setPlayhead, selected, select, onRetime, onMoveTrack, errorsByItem, fps = 30, width,
}: TimelineProps) {
  const root = useRef<HTMLDivElement>(null);
  const lanesRef = useRef<HTMLDivElement>(null);
  const measured = useElementWidth(root);
  const total = width ?? measured;
  const w = Math.max(1, total - GUTTER);
  const [drag, setDrag] = useState<DragState | null>(null);

  const tracks = doc.tracks ?? [];
  const located = allItems(doc);
  const planned = plannedById(plan);
  const laneOfId = new Map(located.map((l) => [l.item.id, l.track]));
  const laneOf = (p: PlannedItem) => laneOfId.get(p.id) ?? p.track;
  const height = Math.max(1, tracks.length) * LANE_HEIGHT;

  useWheel(lanesRef, (e) => {
    const rect = lanesRef.current?.getBoundingClientRect();
    if (!rect) return;
    e.preventDefault();
    setView(wheelTimeView(view, w, e.clientX - rect.left - GUTTER, e));
  });

  const pan = (e: ReactPointerEvent) => {
    const start = view;
    const spp = secondsPerPx(view, w);
    trackPointer(e, (m) => setView(panBy(start, -(m.clientX - e.clientX) * spp)), () => {});
  };

  const onLanesPointerDown = (e: ReactPointerEvent) => {
    if (e.button === 1) {
      e.preventDefault();
      pan(e);
    } else if (e.button === 0) {
      select(null);
    }
  };

  const onBarPointerDown = (e: ReactPointerEvent, id: string) => {
    if (e.button === 1) return; // bubbles to the lanes: pan
    e.stopPropagation();
    if (e.button !== 0) return;
    e.preventDefault();
    const p = planned.get(id);
    const rect = lanesRef.current?.getBoundingClientRect();
    const fromTrack = laneOfId.get(id) ?? 0;
    if (!p || !rect) {
      // an untimed item cannot be dragged in time; a click still selects it
      trackPointer(e, () => {}, () => select(id));
      return;
    }
    const targets = snapTargets(plan, id, doc);
    const dependents = dependentsOf(doc, id);
    const pxPerSecond = w / (view.t1 - view.t0);
    let last: DragState | null = null;
    let horizontal = false;
    let cancelled = false;
    // Escape drops the drag: the bar goes back and nothing is reported.
    const onKey = (k: KeyboardEvent) => {
      if (k.key !== "Escape") return;
      cancelled = true;
      setDrag(null);
    };
    window.addEventListener("keydown", onKey);
    trackPointer(
      e,
      (m) => {
        if (cancelled) return;
        // A move that stays within 3 px horizontally is a lane change only: the start is left alone.
        horizontal ||= Math.abs(m.clientX - e.clientX) > 3;
        const { start, snap } = horizontal
          ? dragTo(p.start, m.clientX - e.clientX, pxPerSecond, targets, m.altKey)
          : { start: p.start, snap: null };
        const track = onMoveTrack ? laneAt(m.clientY - rect.top, tracks.length) : fromTrack;
        if (!last) select(id);
        last = { id, from: p.start, start, snap, track, dependents };
        setDrag(last);
      },
      (_u, moved) => {
        window.removeEventListener("keydown", onKey);
        setDrag(null);
        if (cancelled) return;
        if (!moved || !last) {
          select(id);
          return;
        }
        if (last.snap || Math.abs(last.start - p.start) >= 5e-4) onRetime(id, last.start, last.snap);
        if (onMoveTrack && last.track !== fromTrack) onMoveTrack(id, last.track);
      },
    );
  };

  const links: Link[] = [];
  for (const { item } of located) {
    const self = planned.get(item.id);
    if (!self || !isStartRef(item.start)) continue;
    const base = planned.get(item.start.item);
    const shifted = (p: PlannedItem): PlannedItem => ({ ...p, ...shownSpan(p, drag), anchors: shownAnchors(p, drag) });
    const link = linkFor(item, shifted(self), base && shifted(base), view, w, (p) => (drag?.id === p.id ? drag.track : laneOf(p)));
    if (link) links.push(link);
  }

  return (
    <div ref={root} className="behaviour-timeline" data-testid="behaviour-timeline" style={width != null ? { width } : undefined}>
      <Ruler view={view} setView={setView} fps={fps} duration={plan?.duration ?? 0} playhead={playhead}
             setPlayhead={setPlayhead} width={total} gutter={GUTTER} />
      <div className="bt-scroll">
        <div ref={lanesRef} className="bt-lanes" style={{ height }} onPointerDown={onLanesPointerDown}>
          {tracks.length === 0 && <div className="bt-empty" style={{ left: GUTTER }}>No tracks yet: add one to place items.</div>}
          {tracks.map((track, ti) => {
            const laneErrors = (plan?.errors ?? []).filter((i) => i.track === ti && i.item == null);
            return (
              <div key={ti} className={`bt-lane${ti % 2 ? " odd" : ""}${drag && drag.track === ti && laneOfId.get(drag.id) !== ti ? " drop" : ""}`}
                   data-testid={`behaviour-track-${track.name}`} data-track={ti} style={{ top: laneTop(ti), height: LANE_HEIGHT }}>
                <div className={`bt-lane-name${laneErrors.length ? " has-error" : ""}`} style={{ width: GUTTER }}
                     title={laneErrors.map((i) => i.message).join("\n") || track.name}>
                  <span>{track.name}</span>
                  <span className="bt-count">{(track.items ?? []).length}</span>
                </div>
                <div className="bt-lane-area" style={{ left: GUTTER, width: w }}>
                  {located.filter((l) => (drag?.id === l.item.id ? drag.track : l.track) === ti).map(({ item }) => {
                    const p = planned.get(item.id);
                    const fallback = typeof item.start === "number" ? item.start
                      : isStartRef(item.start) ? (refMoment(plan, item.start) ?? 0) + (item.start.offset ?? 0) : 0;
                    return (
                      <ItemBar key={item.id} item={item} kind={item.kind ?? p?.kind ?? "?"} span={p ? shownSpan(p, drag) : null}
                               planned={p ?? null}
                               fallback={fallback} anchors={p ? shownAnchors(p, drag) : NO_ANCHORS} view={view} width={w}
                               selected={selected === item.id} dragging={drag?.id === item.id}
                               errors={errorsByItem.get(item.id)} onPointerDown={onBarPointerDown} />
                    );
                  })}
                </div>
              </div>
            );
          })}
          {/* after the lanes (so over their backgrounds), under the bars (z-index) */}
          <div className="bt-overlay-box under" style={{ left: GUTTER, width: w, height }}>
            <TimelineOverlay layer="under" view={view} width={w} height={height} links={links} selected={selected}
                             snap={null} playhead={playhead} />
          </div>
          <div className="bt-overlay-box over" style={{ left: GUTTER, width: w, height }}>
            <TimelineOverlay layer="over" view={view} width={w} height={height} links={links} selected={selected}
                             snap={drag?.snap ?? null} playhead={playhead} />
          </div>
          {drag && (
            <div className="bt-drag-readout" style={{ left: GUTTER + Math.max(0, Math.min(w - 140, (drag.start - view.t0) / secondsPerPx(view, w))), top: laneTop(drag.track) - 18 < 0 ? laneTop(drag.track) + LANE_HEIGHT : laneTop(drag.track) - 18 }}>
              {`${drag.start.toFixed(3)} s${drag.snap ? ` → ${drag.snap.item}.${drag.snap.at === "anchor" ? drag.snap.anchor : drag.snap.at}` : ""}`}
            </div>
          )}
        </div>
      </div>
    </div>
  );
}

export default Timeline;
