// The top bar's safety indicator: while the engine's safety net corrects the robot's motion, and for
// RECENT_SECONDS after, which DoFs (and joints no DoF of its own stands for) and by how much at most
// (the program asks for more than the robot may do there). A click plots them in the curve panel.
import { useContext } from "react";
import { SamplesContext } from "../context";
import { useEditor } from "../store/EditorStore";
import { amountText, LIMIT_COLOURS, LIMIT_NAMES, RECENT_SECONDS, recentForBar, seriesOf } from "./net";
import { showCurves } from "./liveUi";

const SHOWN = 4;  // DoFs named in the bar; the others are counted (and all are in the tooltip)

export function SafetyIndicator() {
  const samples = useContext(SamplesContext);
  const { robot } = useEditor().state;
  const recent = recentForBar(samples, robot);
  if (!recent.length) return null;
  const info = new Map(seriesOf(robot).map((s) => [s.key, s]));
  const now = samples.net.at(-1) ?? {};
  const correcting = recent.some((r) => r.key in now);
  const text = (r: (typeof recent)[number]) =>
    `${r.name}${r.key.startsWith("joint:") ? " (joint)" : ""} ${amountText(r.amount, info.get(r.key)?.angular ?? true)}`;
  const more = recent.length - SHOWN;
  const title = `The engine's safety net ${correcting ? "is correcting" : `corrected, in the last ${RECENT_SECONDS} s,`} what the program asks `
    + `(largest |asked − delivered| per DoF, the limit it enforced):\n`
    + recent.map((r) => `${text(r)} (${LIMIT_NAMES[r.limit]})`).join("\n") + "\nClick to plot them in the curve panel.";
  return (
    <button className={`safety-indicator ${correcting ? "now" : "after"}`} data-testid="safety-indicator" title={title}
            data-dofs={recent.map((r) => r.name).join(" ")} onClick={() => showCurves(recent.map((r) => r.key))}>
      <span className="dot" style={{ background: LIMIT_COLOURS[recent[0].limit] }} />
      {correcting ? "Safety net correcting: " : "Safety net corrected: "}
      {recent.slice(0, SHOWN).map(text).join(", ")}{more > 0 ? ` +${more}` : ""}
    </button>
  );
}
