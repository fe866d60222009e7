// Live values while a subgraph is open: its blocks run on the server as `<path>/<id>` (`idle/breathe`),
// the canvas shows them as `<id>`. Subscriptions get the prefix, values come back without it.
import type { SignalRef } from "../api";
import type { Live } from "../telemetry";

export function signalsInside(signals: SignalRef[], path: string | undefined): SignalRef[] {
  return path ? signals.map((s) => ({ node: `${path}/${s.node}`, port: s.port })) : signals;
}

function strip<T>(record: Record<string, T>, prefix: string): Record<string, T> {
  const out: Record<string, T> = {};
  for (const [k, v] of Object.entries(record)) if (k.startsWith(prefix)) out[k.slice(prefix.length)] = v;
  return out;
}

export function liveInside(live: Live, path: string | undefined): Live {
  if (!path) return live;
  const prefix = `${path}/`;
  const profile = live.profile && {
    ...live.profile,
    nodes: live.profile.nodes.filter((n) => n.node.startsWith(prefix)).map((n) => ({ ...n, node: n.node.slice(prefix.length) })),
  };
  return {
    ...live, values: strip(live.values, prefix), history: strip(live.history, prefix), layers: strip(live.layers, prefix), profile,
  };
}
