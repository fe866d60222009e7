// Reroute points: a small dot a wire is drawn through (kept in the program's `ui.reroutes`; the wire
// stays one program edge), and the "routed" edge type that draws a wire through its dots.
import { BaseEdge, type EdgeProps, type NodeProps } from "@xyflow/react";
import { memo } from "react";
import { REROUTE_SIZE, routedPath } from "./annotations";

export const RerouteNode = memo(function RerouteNode({ id, selected }: NodeProps) {
  return <div className={`reroute ${selected ? "selected" : ""}`} data-testid={`reroute-${id}`}
              style={{ width: REROUTE_SIZE, height: REROUTE_SIZE }} title="reroute point (drag to bend the wire, Delete to remove)" />;
});

export function RoutedEdge({ id, sourceX, sourceY, targetX, targetY, data, style, markerEnd }: EdgeProps) {
  const via = (data?.via ?? []) as { x: number; y: number }[];
  return <BaseEdge id={id} path={routedPath(sourceX, sourceY, targetX, targetY, via)} style={style} markerEnd={markerEnd} />;
}
