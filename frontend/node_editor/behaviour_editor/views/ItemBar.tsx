// One item on a behaviour timeline lane: a bar over its planned [start, end] coloured by kind (a flag for
// an item that takes no time), labelled, with a tick per clip anchor; red-outlined with its messages in
// the tooltip when it has errors. Untimed items (the plan could not place them) show dashed.
import { memo } from "react";
import type { CSSProperties, PointerEvent as ReactPointerEvent } from "react";
import type { TimeView } from "../../clip_editor/views/timeView";
import { timeToX } from "../../clip_editor/views/timeView";
import type { ItemDoc, Issue } from "../model/types";
import { kindInfo } from "../model/types";
import { BAR_HEIGHT, LANE_HEIGHT, barBox, describeStart, itemSummary } from "./layout";

export interface ItemBarProps {
  item: ItemDoc;
  kind: string;
  /** where the bar shows (s): the plan's span, moved while a drag moves it; null when not planned */
  span: { start: number; end: number } | null;
  /** the plan's span (s), written to data-start/data-end (what the browser tests read) */
  planned: { start: number; end: number } | null;
  /** where an untimed item is drawn (s) */
  fallback: number;
  anchors: Record<string, number>;
  view: TimeView;
  width: number;
  selected: boolean;
  dragging: boolean;
  errors: Issue[] | undefined;
  onPointerDown: (e: ReactPointerEvent, id: string) => void;
}

const fmt = (t: number) => `${+t.toFixed(3)} s`;

function tooltip(item: ItemDoc, kind: string, span: ItemBarProps["span"], errors: Issue[] | undefined): string {
  const lines = [`${item.id} · ${kindInfo(kind).label}`];
  lines.push(span ? `${fmt(span.start)} – ${fmt(span.end)} (start: ${describeStart(item.start)})` : `not timed (start: ${describeStart(item.start)})`);
  if (item.label) lines.push(itemSummary({ ...item, label: "" }));
  for (const e of errors ?? []) lines.push(`⚠ ${e.field ? `${e.field}: ` : ""}${e.message}`);
  return lines.join("\n");
}

function ItemBarImpl({ item, kind, span, planned, fallback, anchors, view, width, selected, dragging, errors, onPointerDown }: ItemBarProps) {
  const at = span ?? { start: fallback, end: fallback };
  const box = span ? barBox(view, width, kind, at.start, at.end) : barBox(view, width, kind, fallback, fallback);
  // Far off-screen bars are not drawn (the lane clips them anyway), so a long behaviour stays cheap.
  if (box.x > width + 400 || box.x + box.width < -400) return null;
  const info = kindInfo(kind);
  const classes = ["bt-item", box.instant ? "instant" : "span", selected && "selected", errors?.length && "has-error",
    !span && "untimed", dragging && "dragging"].filter(Boolean).join(" ");
  const summary = itemSummary(item);
  return (
    <div
      className={classes}
      data-testid={`behaviour-item-${item.id}`}
      data-kind={kind}
      data-start={planned ? String(planned.start) : undefined}
      data-end={planned ? String(planned.end) : undefined}
      title={tooltip(item, kind, span, errors)}
      style={{
        left: box.x,
        width: box.width,
        top: (LANE_HEIGHT - BAR_HEIGHT) / 2,
        height: BAR_HEIGHT,
        "--bar": `var(${info.colour})`,
      } as CSSProperties}
      onPointerDown={(e) => onPointerDown(e, item.id)}
    >
      {box.instant ? <span className="bt-flag" /> : null}
      {!box.instant && Object.entries(anchors).map(([name, t]) => (
        <span key={name} className="bt-anchor" style={{ left: timeToX(view, width, t) - box.x }} title={`anchor ${name}`} />
      ))}
      <span className="bt-label">
        {errors?.length ? <b className="bt-warn">⚠</b> : null}
        {summary}
      </span>
    </div>
  );
}

export const ItemBar = memo(ItemBarImpl);
