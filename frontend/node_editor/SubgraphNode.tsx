// A node using a subgraph: its name and its definition's, its exposed ports (typed like the inner ports
// they stand for), error badges for problems inside, and a button to open it (or double-click). Zoomed
// out it collapses like a block: its name enlarged and its ports without labels.
import { Handle, Position, useUpdateNodeInternals, type NodeProps } from "@xyflow/react";
import { memo, useContext, useEffect } from "react";
import { COMPACT_ROW, COMPACT_ROWS_TOP, CompactHandles, LiveRows, PORT_COLOURS } from "./BlockNode";
import { HANDLE_TOP, LIVE_ROW_HEIGHT, PORT_ROW_HEIGHT, PORT_ROWS_TOP } from "./layout/constants";
import { CookBadge, WarningBadge } from "./live/NodeBadges";
import { NodeTitle } from "./NodeTitle";
import { useFaded } from "./wireDrop";
import { OrganiseContext } from "./organise/context";
import type { NodeData } from "./graph";
import { useCompact } from "./viewport";

/** Room in the body beside its rows (above and below them). */
const BODY_PADDING = 8;

export const SubgraphNode = memo(function SubgraphNode({ id, data, selected }: NodeProps & { data: NodeData }) {
  const { openSubgraph } = useContext(OrganiseContext);
  const ins = Object.entries(data.inputs);
  const outs = Object.entries(data.outputs);
  const rows = Math.max(ins.length, outs.length, 1);
  const name = String(data.params.subgraph ?? "?");
  const compact = useCompact();
  // while a wire is dragged, the ports that cannot take it fade
  const faded = useFaded(id);
  const updateInternals = useUpdateNodeInternals();
  useEffect(() => updateInternals(id), [compact, id, updateInternals]);
  const openButton = (
    <button className="nodrag open-subgraph" data-testid={`open-${id}`} title="Open the subgraph to edit its blocks"
            onClick={(e) => { e.stopPropagation(); openSubgraph(id); }}>Open</button>
  );
  const classes = `block subgraph-node ${selected ? "selected" : ""} ${data.errors.length ? "has-error" : ""}`;
  if (compact) return (
    <div className={`${classes} compact`} data-testid={`node-${id}`} aria-label={`subgraph ${name} ${id}`} onDoubleClick={() => openSubgraph(id)}>
      <div className="block-header subgraph-header">
        <NodeTitle id={id} kind={`▣ ${name}`} />
        {data.errors.length > 0 && <span className="badge" data-testid={`error-${id}`} title={data.errors.join("\n")}>{data.errors.length}</span>}
        <WarningBadge id={id} />
        {openButton}
      </div>
      <div className="block-body" style={{ height: rows * COMPACT_ROW + 2 * COMPACT_ROWS_TOP }}>
        <CompactHandles id={id} ins={ins} outs={outs} titleOf={(port, p) => `${port}: ${p.type} — ${p.doc}`} />
      </div>
    </div>
  );
  return (
    <div className={classes} data-testid={`node-${id}`} aria-label={`subgraph ${name} ${id}`} onDoubleClick={() => openSubgraph(id)}>
      <div className="block-header subgraph-header">
        <NodeTitle id={id} kind={`▣ ${name}`} />
        {data.errors.length > 0 && <span className="badge" data-testid={`error-${id}`} title={data.errors.join("\n")}>{data.errors.length}</span>}
        <WarningBadge id={id} />
        <CookBadge id={id} />
        {openButton}
      </div>
      <div className="block-body" style={{ minHeight: rows * PORT_ROW_HEIGHT + BODY_PADDING + outs.length * LIVE_ROW_HEIGHT }}>
        {ins.map(([port, p], i) => (
          <div key={`in-${port}`} className="port-row in" style={{ top: PORT_ROWS_TOP + i * PORT_ROW_HEIGHT }}>
            <Handle type="target" position={Position.Left} id={port} className={`handle ${p.type}${faded("target", port)}`}
                    style={{ background: PORT_COLOURS[p.type], top: HANDLE_TOP }} title={`${port}: ${p.type} — ${p.doc}`} />
            <span className="port-label">{port}</span>
          </div>
        ))}
        {outs.map(([port, p], i) => (
          <div key={`out-${port}`} className="port-row out" style={{ top: PORT_ROWS_TOP + i * PORT_ROW_HEIGHT }}>
            <span className="port-label">{port}</span>
            <Handle type="source" position={Position.Right} id={port} className={`handle ${p.type}${faded("source", port)}`}
                    style={{ background: PORT_COLOURS[p.type], top: HANDLE_TOP }} title={`${port}: ${p.type} — ${p.doc}`} />
          </div>
        ))}
        <LiveRows id={id} ports={outs.map(([port]) => port)} top={PORT_ROWS_TOP + rows * PORT_ROW_HEIGHT} />
      </div>
      {data.errors.length > 0 && <div className="block-errors">{data.errors[0]}</div>}
    </div>
  );
});
