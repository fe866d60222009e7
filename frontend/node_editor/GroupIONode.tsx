// The open subgraph's "Group Input" / "Group Output" stand-in (./groupIO): the exposed ports by their
// outer names, each a handle wired to the inner port it stands for. Drawn like a block, view only.
import { Handle, Position, type NodeProps } from "@xyflow/react";
import { memo } from "react";
import { PORT_COLOURS } from "./BlockNode";
import type { NodeData } from "./graph";
import { HANDLE_TOP, PORT_ROW_HEIGHT, PORT_ROWS_TOP } from "./layout/constants";

/** Room in the body below its rows. */
const BODY_BOTTOM = 8;

export const GroupIONode = memo(function GroupIONode({ id, data }: NodeProps & { data: NodeData }) {
  const side = Object.keys(data.outputs).length ? "source" : "target";
  const ports = Object.entries(side === "source" ? data.outputs : data.inputs);
  return (
    <div className="block group-io" data-testid={`node-${id}`} aria-label={data.type}
         title="Where the subgraph's exposed ports go (edit them with Exposed ports…)">
      <div className="block-header">
        <span className="block-title-box"><span className="block-title">{data.type}</span><span className="block-type">exposed ports</span></span>
      </div>
      <div className="block-body" style={{ minHeight: PORT_ROWS_TOP + ports.length * PORT_ROW_HEIGHT + BODY_BOTTOM }}>
        {ports.map(([name, p], i) => (
          <div key={name} className={`port-row ${side === "source" ? "out" : "in"}`} style={{ top: PORT_ROWS_TOP + i * PORT_ROW_HEIGHT }}>
            {side === "target" && <Handle type="target" position={Position.Left} id={name} className={`handle ${p.type}`} isConnectable={false}
                                          style={{ background: PORT_COLOURS[p.type], top: HANDLE_TOP }} title={`${name} ← ${p.doc}`} />}
            <span className="port-label" data-testid={`group-port-${name}`}>{name}</span>
            {side === "source" && <Handle type="source" position={Position.Right} id={name} className={`handle ${p.type}`} isConnectable={false}
                                          style={{ background: PORT_COLOURS[p.type], top: HANDLE_TOP }} title={`${name} → ${p.doc}`} />}
          </div>
        ))}
      </div>
    </div>
  );
});
