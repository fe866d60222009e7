// What the behaviour timeline draws across its lanes: under the bars, a thin line from each relative
// item to the moment it is timed from; over them, the snap guide while a drag snaps, and the playhead.
import type { TimeView } from "../../clip_editor/views/timeView";
import { timeToX } from "../../clip_editor/views/timeView";
import type { SnapTarget } from "../model/types";
import type { Link } from "./layout";

export interface TimelineOverlayProps {
  view: TimeView;
  width: number;
  height: number;
  links: Link[];
  selected: string | null;
  snap: SnapTarget | null;
  playhead: number;
  /** "under" the bars: the links; "over" them: the snap guide and playhead */
  layer: "under" | "over";
}

export function TimelineOverlay({ view, width, height, links, selected, snap, playhead, layer }: TimelineOverlayProps) {
  const px = timeToX(view, width, playhead);
  const sx = snap ? timeToX(view, width, snap.t) : 0;
  if (layer === "under") {
    return (
      <svg className="bt-overlay" width={width} height={height}>
        {links.map((l) => {
        const mid = (l.y1 + l.y2) / 2;
        const hot = selected != null && (l.from === selected || l.to === selected);
        return (
          <g key={`${l.from}>${l.to}`} className={`bt-link${hot ? " hot" : ""}`}>
            <path d={`M${l.x1} ${l.y1} C${l.x1} ${mid} ${l.x2} ${mid} ${l.x2} ${l.y2}`} />
            <circle cx={l.x1} cy={l.y1} r={2.5} />
          </g>
        );
      })}
      </svg>
    );
  }
  return (
    <svg className="bt-overlay" width={width} height={height}>
      {snap && (
        <g className="bt-snap-guide" data-testid="behaviour-snap-guide" data-t={snap.t} data-item={snap.item} data-at={snap.at}>
          <line x1={sx} x2={sx} y1={0} y2={height} />
          <text x={sx + 4} y={11}>{`${snap.item}.${snap.at === "anchor" ? snap.anchor : snap.at}`}</text>
        </g>
      )}
      {px >= 0 && px <= width && <line className="playhead-line" x1={px} x2={px} y1={0} y2={height} />}
    </svg>
  );
}
