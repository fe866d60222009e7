// Which blocks the find box (Ctrl+F) offers for a query: matched by node id (its name) and block type,
// best first. Pure (tested with vitest).
import type { Catalog } from "./api";
import type { FlowNode } from "./graph";

export interface Found { id: string; type: string; title: string }

/** How well `text` matches `q` (lower is better), or null: whole, start, word start, inside, then the
 * query's letters in order (a fuzzy match, "wf" finding "wander_filter"). */
function score(text: string, q: string): number | null {
  const t = text.toLowerCase();
  if (t === q) return 0;
  if (t.startsWith(q)) return 1;
  if (t.split(/[_\-\s./]/).some((w) => w.startsWith(q))) return 2;
  if (t.includes(q)) return 3;
  let at = 0;
  for (const c of t) if (c === q[at]) at++;
  return at === q.length ? 5 : null;
}

/** The blocks and subgraph nodes of `nodes` that match `query` (all of them, by name, when it is empty). */
export function findBlocks(nodes: FlowNode[], catalog: Catalog, query: string): Found[] {
  const q = query.trim().toLowerCase();
  const ranked: { found: Found; rank: number }[] = [];
  for (const n of nodes) {
    if (n.type !== "block" && n.type !== "subgraph") continue;
    const type = n.data.type;
    const title = catalog[type]?.title ?? (type === "subgraph" ? `subgraph ${String(n.data.params.subgraph ?? "")}` : type);
    // the name counts more than the type: a type's match comes after any name's of the same kind
    const byName = q ? score(n.id, q) : 0;
    const byType = q ? Math.min(score(type, q) ?? Infinity, score(title, q) ?? Infinity) : Infinity;
    const rank = Math.min(byName ?? Infinity, byType + 0.5);
    if (rank !== Infinity) ranked.push({ found: { id: n.id, type, title }, rank });
  }
  ranked.sort((a, b) => a.rank - b.rank || a.found.id.localeCompare(b.found.id));
  return ranked.map((r) => r.found);
}
