// One block on the graph: a header coloured by category, typed ports (frame ports wide and white,
// one colour per signal type), the live value of each output, and error badges from the server.
import { Handle, Position, useUpdateNodeInternals, type NodeProps } from "@xyflow/react";
import { memo, useContext, useEffect, type CSSProperties } from "react";
import type { NodeData } from "./graph";
import { LiveContext, CatalogContext } from "./context";
import { NodeTitle } from "./NodeTitle";
import { useFaded } from "./wireDrop";
import { useActions } from "./store/EditorStore";
import { HANDLE_TOP, LIVE_ROW_HEIGHT, PORT_ROW_HEIGHT, PORT_ROWS_TOP } from "./layout/constants";
import { CookBadge, WarningBadge, WarningLine } from "./live/NodeBadges";
import { NetRows } from "./live/NetRows";
import { useCompact } from "./viewport";

/** Port row pitch (px) of a collapsed block or subgraph node, its rows' top (and room below them), and a
 * block's least body height. */
export const COMPACT_ROW = 20;
export const COMPACT_ROWS_TOP = 4;
const COMPACT_BODY_MIN_HEIGHT = 36;

type PortEntry = [string, NodeData["inputs"][string]];

/** A collapsed node's ports: handles without labels, inputs left and outputs right, one row each. */
export function CompactHandles({ id, ins, outs, titleOf }: {
  id: string; ins: PortEntry[]; outs: PortEntry[]; titleOf: (name: string, p: PortEntry[1]) => string;
}) {
  const faded = useFaded(id);
  const side = (list: PortEntry[], type: "target" | "source") => list.map(([name, p], i) => (
    <Handle key={`${type}-${name}`} type={type} position={type === "target" ? Position.Left : Position.Right} id={name}
            className={`handle ${p.type}${faded(type, name)}`} title={titleOf(name, p)}
            style={{ background: PORT_COLOURS[p.type], top: COMPACT_ROWS_TOP + i * COMPACT_ROW + COMPACT_ROW / 2 }} />
  ));
  return <>{side(ins, "target")}{side(outs, "source")}</>;
}
/** Room below a full block's last live row. */
const BODY_BOTTOM = 4;
/** A live value's sparkline: its size, and the margin keeping its line off the top and bottom edges. */
const SPARKLINE = { width: 60, height: 16, inset: 2 };

export const PORT_COLOURS: Record<string, string> = {
  frame: "#f2f2f2",
  float: "#4fc3f7",
  int: "#26a69a",
  bool: "#ef5350",
  string: "#ffca28",
  vec3: "#ab47bc",
  colour: "#ec407a",
  event: "#ff7043",
};

export const CATEGORY_COLOURS: Record<string, string> = {
  sources: "#2e7d5b",
  operators: "#3559a8",
  layers: "#7a4fb0",
  stage2: "#b0642a",
  signals: "#56606e",
  output: "#a23a4d",
};

function Sparkline({ values }: { values: number[] }) {
  if (values.length < 2) return null;
  const lo = Math.min(...values), hi = Math.max(...values);
  const span = hi - lo || 1;
  const { width, height, inset } = SPARKLINE;
  const pts = values.map((v, i) => `${(i / (values.length - 1)) * width},${height - inset - ((v - lo) / span) * (height - 2 * inset)}`).join(" ");
  return (
    <svg className="spark" width={width} height={height} aria-hidden>
      <polyline points={pts} fill="none" stroke="#8fd3ff" strokeWidth="1.2" />
    </svg>
  );
}

function formatValue(v: unknown): string {
  if (v === null || v === undefined) return "–";
  if (typeof v === "number") return Math.abs(v) >= 100 ? v.toFixed(0) : v.toFixed(3);
  if (typeof v === "boolean") return v ? "true" : "false";
  if (Array.isArray(v)) return "[" + v.map((x) => (typeof x === "number" ? x.toFixed(2) : String(x))).join(", ") + "]";
  if (typeof v === "object" && v && "mask" in v) {
    const f = v as { mask: number; values: Record<string, number> };
    const first = Object.entries(f.values)[0];
    return first ? `${f.mask} DoFs · ${first[0]} ${first[1].toFixed(3)}` : "empty frame";
  }
  return String(v);
}

/** The live value and sparkline of each output port, in rows from `top` (px) down. */
export function LiveRows({ id, ports, top }: { id: string; ports: string[]; top: number }) {
  const live = useContext(LiveContext);
  return (
    <>
      {ports.map((name, i) => {
        const key = `${id}.${name}`;
        return (
          <div key={`live-${name}`} className="live-row" style={{ top: top + i * LIVE_ROW_HEIGHT }}>
            <span className="live-port">{name}</span>
            <span className="live" data-testid={`live-${key}`}>{formatValue(live.values[key])}</span>
            <Sparkline values={live.history[key] ?? []} />
          </div>
        );
      })}
    </>
  );
}

type LayerParam = { name: string; mode?: string; weight?: number; active?: boolean };

/** A mixer's layers: the checkbox is the program's `active` (saved, undoable, a live patch), the bar the
 * engine's effective weight. */
function LayerRows({ id, params, top }: { id: string; params: Record<string, unknown>; top: number }) {
  const live = useContext(LiveContext);
  const { editParams } = useActions();
  const layers = Array.isArray(params.layers) ? (params.layers as LayerParam[]) : null;
  if (!layers?.length) return null;
  const effective = Object.fromEntries((live.layers[id] ?? []).map((l) => [l.name, l.effective]));
  const setActive = (i: number, active: boolean) =>
    editParams(id, { ...params, layers: layers.map((l, k) => (k === i ? { ...l, active } : l)) });
  return (
    <div className="layers" style={{ marginTop: top }}>
      {layers.map((l, i) => (
        <div key={l.name} className="layer-row" title={`${l.mode ?? "override"}, weight ${l.weight ?? 1}`}>
          <input type="checkbox" className="nodrag" checked={l.active ?? true} aria-label={`layer ${l.name} on`}
                 data-testid={`layer-${id}-${l.name}`} onChange={(e) => setActive(i, e.target.checked)} />
          <span className="layer-name">{l.name}</span>
          <span className="layer-mode">{l.mode ?? "override"}</span>
          <span className="layer-bar"><span style={{ width: `${Math.round((effective[l.name] ?? 0) * 100)}%` }} /></span>
        </div>
      ))}
    </div>
  );
}

export const BlockNode = memo(function BlockNode({ id, data, selected }: NodeProps & { data: NodeData }) {
  const catalog = useContext(CatalogContext);
  const entry = catalog[data.type];
  const colour = CATEGORY_COLOURS[entry?.category ?? "signals"] ?? "#555";
  const ins = Object.entries(data.inputs);
  const outs = Object.entries(data.outputs);
  const rows = Math.max(ins.length, outs.length, 1);
  const liveTop = PORT_ROWS_TOP + rows * PORT_ROW_HEIGHT;
  // level of detail: zoomed out, a block is its enlarged title and its ports (no labels, values, layers)
  const compact = useCompact();
  // while a wire is dragged, the ports that cannot take it fade
  const faded = useFaded(id);
  const updateInternals = useUpdateNodeInternals();
  useEffect(() => updateInternals(id), [compact, id, updateInternals]);
  const kind = entry?.title ?? data.type;
  const classes = `block ${selected ? "selected" : ""} ${data.errors.length ? "has-error" : ""} ${data.bypass ? "bypassed" : ""}`;
  const bypassTag = data.bypass ? <span className="bypass-tag" data-testid={`bypassed-${id}`}>bypassed</span> : null;
  if (compact) return (
    <div className={`${classes} compact`} data-testid={`node-${id}`} aria-label={`${kind} ${id}`} style={{ "--cat": colour } as CSSProperties}>
      <div className="block-header" style={{ background: colour }}>
        <NodeTitle id={id} kind={kind} />
        {bypassTag}
        {data.errors.length > 0 && <span className="badge" data-testid={`error-${id}`} title={data.errors.join("\n")}>{data.errors.length}</span>}
        <WarningBadge id={id} />
        <NetRows id={id} type={data.type} compact />
      </div>
      <div className="block-body" style={{ height: Math.max(rows * COMPACT_ROW + 2 * COMPACT_ROWS_TOP, COMPACT_BODY_MIN_HEIGHT) }}>
        <div className="compact-cook"><CookBadge id={id} /></div>
        <CompactHandles id={id} ins={ins} outs={outs} titleOf={(name, p) => `${name}: ${p.type}`} />
      </div>
    </div>
  );
  return (
    <div className={classes} data-testid={`node-${id}`} aria-label={`${kind} ${id}`} title={entry?.doc}>
      <div className="block-header" style={{ background: colour }}>
        <NodeTitle id={id} kind={kind} />
        {bypassTag}
        {data.errors.length > 0 && <span className="badge" data-testid={`error-${id}`} title={data.errors.join("\n")}>{data.errors.length}</span>}
        <WarningBadge id={id} />
        <CookBadge id={id} />
      </div>
      <div className="block-body" style={{ minHeight: liveTop + outs.length * LIVE_ROW_HEIGHT + BODY_BOTTOM }}>
        {ins.map(([name, p], i) => (
          <div key={`in-${name}`} className="port-row in" style={{ top: PORT_ROWS_TOP + i * PORT_ROW_HEIGHT }}>
            <Handle type="target" position={Position.Left} id={name} className={`handle ${p.type}${faded("target", name)}`}
                    style={{ background: PORT_COLOURS[p.type], top: HANDLE_TOP }} title={`${name}: ${p.type}${p.doc ? " — " + p.doc : ""}`} />
            <span className="port-label">{name}</span>
          </div>
        ))}
        {outs.map(([name, p], i) => (
          <div key={`out-${name}`} className="port-row out" style={{ top: PORT_ROWS_TOP + i * PORT_ROW_HEIGHT }}>
            <span className="port-label">{name}</span>
            <Handle type="source" position={Position.Right} id={name} className={`handle ${p.type}${faded("source", name)}`}
                    style={{ background: PORT_COLOURS[p.type], top: HANDLE_TOP }} title={`${name}: ${p.type}`} />
          </div>
        ))}
        <LiveRows id={id} ports={outs.map(([name]) => name)} top={liveTop} />
        <LayerRows id={id} params={data.params} top={liveTop + outs.length * LIVE_ROW_HEIGHT} />
      </div>
      {data.errors.length > 0 && <div className="block-errors">{data.errors[0]}</div>}
      <WarningLine id={id} hidden={data.errors.length > 0} />
      <NetRows id={id} type={data.type} />
    </div>
  );
});
