// What a subgraph node shows of the running program: the engine runs its blocks flattened
// (`idle/breathe`), so the node's outputs are the inner ports they expose (`idle.out` stands for
// `idle/eyelid_filter.out`, through nested subgraphs) and its cook time is the sum of its blocks'.
import type { NodeCookTime, Profile, SignalRef } from "../api";
import { SUBGRAPH, type FlowNode, type SubgraphDef } from "../graph";
import type { Live } from "../telemetry";

type Defs = Record<string, SubgraphDef> | undefined | null;

/** The flat signal behind output `port` of the subgraph node `node` (type and params as in the
 * program), under the flat id `id`; null when the definition does not expose it (or loops). */
export function exposedSignal(id: string, node: { type: string; params?: Record<string, unknown> }, port: string,
  defs: Defs, seen: string[] = []): SignalRef | null {
  const name = String(node.params?.subgraph ?? "");
  const def = defs?.[name];
  if (node.type !== SUBGRAPH || !def || seen.includes(name)) return null;
  const out = (def.outputs ?? []).find((o) => o.name === port);
  const inner = out && (def.nodes ?? []).find((n) => n.id === out.node);
  if (!out || !inner) return null;
  const innerId = `${id}/${inner.id}`;
  if (inner.type === SUBGRAPH) return exposedSignal(innerId, inner, out.port, defs, [...seen, name]);
  return { node: innerId, port: out.port };
}

/** `"<node>.<port>"` of every subgraph node's output -> the flat signal it stands for. */
export function subgraphAliases(nodes: FlowNode[], defs: Defs): Record<string, SignalRef> {
  const out: Record<string, SignalRef> = {};
  for (const n of nodes) {
    if (n.data.type !== SUBGRAPH) continue;
    for (const port of Object.keys(n.data.outputs)) {
      const flat = exposedSignal(n.id, { type: n.data.type, params: n.data.params }, port, defs);
      if (flat) out[`${n.id}.${port}`] = flat;
    }
  }
  return out;
}

/** The subscription with the flat signals behind subgraph outputs instead of the outputs themselves. */
export function withAliasedSignals(signals: SignalRef[], aliases: Record<string, SignalRef>): SignalRef[] {
  if (!Object.keys(aliases).length) return signals;
  return signals.map((s) => aliases[`${s.node}.${s.port}`] ?? s);
}

/** Sum of the cook times of the blocks inside `id` (a subgraph instance), as one entry; null if none. */
export function cookTimeInside(profile: Profile, id: string): NodeCookTime | null {
  const inner = profile.nodes.filter((n) => n.node.startsWith(`${id}/`));
  if (!inner.length) return null;
  const sum = (k: "mean_us" | "p50_us" | "p99_us" | "max_us" | "share") => inner.reduce((a, n) => a + n[k], 0);
  return { node: id, type: SUBGRAPH, mean_us: sum("mean_us"), p50_us: sum("p50_us"), p99_us: sum("p99_us"),
           max_us: sum("max_us"), share: sum("share") } as NodeCookTime;
}

/** Live values with each subgraph output's value and history under the output's own name. */
export function withAliasedValues(live: Live, aliases: Record<string, SignalRef>): Live {
  const keys = Object.keys(aliases);
  if (!keys.length) return live;
  const values = { ...live.values }, history = { ...live.history };
  for (const key of keys) {
    const flat = `${aliases[key].node}.${aliases[key].port}`;
    if (flat in live.values) values[key] = live.values[flat];
    if (flat in live.history) history[key] = live.history[flat];
  }
  return { ...live, values, history };
}
