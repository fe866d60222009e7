// Recording a take: pick the DoFs (default: the selected ones, else the moved pose DoFs), a 3-2-1
// count-in, then the server records what the robot plays (POST /api/record/start) until Stop, which
// saves the take as a clip (POST /api/record/stop); the take opens in the editor and its report shows.
import { useEffect, useRef, useState } from "react";
import { clipApi, type RecordResult } from "./clipApi";
import { refusalOf } from "./clipErrors";
import type { DofInfo } from "./model/types";

export interface RecordControlsProps {
  clipName: string;
  /** The DoFs a take records unless the user picks others. */
  defaultDofs: string[];
  dofs: DofInfo[];
  /** A take was saved: open it. */
  onRecorded: (result: RecordResult) => void;
}

type Phase = { kind: "idle" } | { kind: "countin"; n: number } | { kind: "recording"; since: number } | { kind: "stopping" };

const COUNT_IN = 3;

/** One line per broken limit of a take's report, or "limits ok". */
export function reportSummary(r: RecordResult): { keys: string; error: string; limits: string } {
  const keys = Object.entries(r.keys).map(([d, n]) => `${d}: ${n}`).join(", ");
  const broken = [...new Set(r.report.ranges.map((x) => `${x.dof} ${x.kind}`))];
  return {
    keys: keys || "no keys",
    error: `max error ${r.max_error.toFixed(4)} rad over ${r.samples} samples (${r.duration.toFixed(2)} s)`,
    limits: r.report.ok || !broken.length ? "limits ok" : `over the limits: ${broken.join(", ")}`,
  };
}

export function RecordControls({ clipName, defaultDofs, dofs, onRecorded }: RecordControlsProps) {
  const [phase, setPhase] = useState<Phase>({ kind: "idle" });
  const [picked, setPicked] = useState<string[] | null>(null);  // null: the defaults
  const [take, setTake] = useState(1);
  const [takeName, setTakeName] = useState<string | null>(null);
  const [error, setError] = useState<string | null>(null);
  const [report, setReport] = useState<RecordResult | null>(null);
  const [now, setNow] = useState(0);
  const chosen = picked ?? defaultDofs;
  const name = takeName ?? `${clipName}-take-${take}`;
  const cancelled = useRef(false);

  // the count-in: one number a second, then the recording starts
  useEffect(() => {
    if (phase.kind !== "countin") return;
    const timer = window.setTimeout(() => {
      if (phase.n > 1) { setPhase({ kind: "countin", n: phase.n - 1 }); return; }
      clipApi.recordStart(chosen).then(() => {
        if (cancelled.current) { void clipApi.recordCancel().catch(() => undefined); return; }
        setPhase({ kind: "recording", since: performance.now() });
      }).catch((e: unknown) => { setError(refusalOf(e).message); setPhase({ kind: "idle" }); });
    }, 1000);
    return () => window.clearTimeout(timer);
  }, [phase, chosen]);

  useEffect(() => {
    if (phase.kind !== "recording") return;
    const timer = window.setInterval(() => setNow(performance.now()), 100);
    return () => window.clearInterval(timer);
  }, [phase]);

  const start = () => {
    if (!chosen.length) { setError("pick the DoFs to record (select tracks or move pose sliders)"); return; }
    cancelled.current = false;
    setError(null);
    setReport(null);
    setPhase({ kind: "countin", n: COUNT_IN });
  };
  const stop = () => {
    setPhase({ kind: "stopping" });
    clipApi.recordStop(name).then((r) => {
      setReport(r);
      setTake((n) => n + 1);
      setTakeName(null);
      setPhase({ kind: "idle" });
      onRecorded(r);
    }).catch((e: unknown) => { setError(refusalOf(e).message); setPhase({ kind: "idle" }); });
  };
  const cancel = () => {
    cancelled.current = true;
    if (phase.kind === "recording") clipApi.recordCancel().catch((e: unknown) => setError(refusalOf(e).message));
    setPhase({ kind: "idle" });
  };
  const toggleDof = (d: string) => setPicked(chosen.includes(d) ? chosen.filter((x) => x !== d) : [...chosen, d]);
  const busy = phase.kind !== "idle";
  const summary = report && reportSummary(report);

  return (
    <div className="record-controls">
      {!busy && <button type="button" data-testid="clip-record" className="record" onClick={start}
                        title={`record ${chosen.join(", ") || "(no DoFs)"} after a 3-2-1 count-in`}>● Record</button>}
      {busy && <button type="button" data-testid="clip-record-stop" onClick={stop} disabled={phase.kind !== "recording"}>■ Stop recording</button>}
      {busy && <button type="button" data-testid="record-cancel" onClick={cancel} disabled={phase.kind === "stopping"}>Cancel</button>}
      {phase.kind === "recording" && <span className="record-elapsed" data-testid="record-elapsed">{(Math.max(0, now - phase.since) / 1000).toFixed(1)} s</span>}
      <details className="record-options">
        <summary title="the DoFs a take records and its name">{chosen.length} DoF{chosen.length === 1 ? "" : "s"}</summary>
        <div className="record-popover">
          <label>Take <input data-testid="record-take-name" value={name} onChange={(e) => setTakeName(e.target.value)} /></label>
          <button type="button" onClick={() => setPicked(null)} disabled={picked === null}>Defaults</button>
          <div className="record-dofs">
            {dofs.map((d) => (
              <label key={d.name}><input type="checkbox" data-testid={`record-dof-${d.name}`} checked={chosen.includes(d.name)}
                                         onChange={() => toggleDof(d.name)} /> {d.name}</label>
            ))}
          </div>
        </div>
      </details>
      {phase.kind === "countin" && <div className="record-countin" data-testid="record-countin">{phase.n}</div>}
      {error && <span className="clip-error-text" data-testid="record-error">{error}</span>}
      {summary && (
        <div className="record-report" data-testid="record-report">
          <strong>{report.saved}</strong> <span>{summary.keys}</span> <span>{summary.error}</span>
          <span className={report.report.ok ? "ok" : "bad"}>{summary.limits}</span>
          <button type="button" aria-label="close the report" onClick={() => setReport(null)}>×</button>
        </div>
      )}
    </div>
  );
}
