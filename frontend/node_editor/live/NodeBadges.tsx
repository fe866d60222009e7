// What a block shows of the running program beyond its values: its cook time (a badge, and a heat
// stripe from cool to hot against the program's most expensive node) and the report's warnings about
// it (amber, like errors are red).
import { createContext, useContext } from "react";
import { LiveContext } from "../context";
import { cookText, heat, heatColour, heatScale } from "./logic";
import { useLiveUi } from "./liveUi";
import { cookTimeInside } from "./subgraphLive";

/** The report's warnings by node id (provided by the graph view). */
export const WarningsContext = createContext<Record<string, string[]>>({});

export function CookBadge({ id }: { id: string }) {
  const { profile } = useContext(LiveContext);
  const { heat: showHeat } = useLiveUi();
  if (!profile) return null;
  // a subgraph node costs what its blocks cost (they run flattened, as `<id>/<block>`)
  const mine = profile.nodes.find((n) => n.node === id) ?? cookTimeInside(profile, id);
  if (!mine) return <span className="cook-badge none" data-testid={`cook-${id}`} title="not timed (not in the tick)">–</span>;
  const us = mine.p50_us;
  const h = heat(us, heatScale(profile.nodes.map((n) => n.p50_us)));
  const colour = heatColour(h);
  const title = `cook time per tick: median ${cookText(mine.p50_us)}, mean ${cookText(mine.mean_us)}, p99 ${cookText(mine.p99_us)}, `
    + `max ${cookText(mine.max_us)}; ${(mine.share * 100).toFixed(1)}% of the tick (${profile.samples} timed ticks)`;
  return (
    <>
      <span className="cook-badge" data-testid={`cook-${id}`} data-heat={h.toFixed(2)} title={title}
            style={showHeat ? { background: colour } : undefined}>{cookText(us)}</span>
      {showHeat && <span className="heat-strip" style={{ background: colour }} aria-hidden />}
    </>
  );
}

export function WarningBadge({ id }: { id: string }) {
  const mine = useContext(WarningsContext)[id];
  if (!mine?.length) return null;
  return <span className="warn-badge" data-testid={`warning-${id}`} title={mine.join("\n")}>⚠ {mine.length}</span>;
}

export function WarningLine({ id, hidden }: { id: string; hidden?: boolean }) {
  const mine = useContext(WarningsContext)[id];
  if (hidden || !mine?.length) return null;
  return <div className="block-warnings">{mine[0]}{mine.length > 1 ? ` (+${mine.length - 1})` : ""}</div>;
}
