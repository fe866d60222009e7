// The server's plan of the working copy (POST /api/behaviours/plan): every item's exact start and end,
// anchors and errors, asked again ~150 ms after edits pause (or the preview params change). The newest
// answer wins; the previous plan stays on screen meanwhile so bars do not flicker.
import { useEffect, useState } from "react";
import { behaviourApi, issuesOf } from "./behaviourApi";
import type { BehaviourDoc, Plan } from "./model/types";

export const PLAN_DEBOUNCE_MS = 150;

export const EMPTY_PLAN: Plan = { valid: true, duration: 0, params: {}, items: [], errors: [] };

export function usePlan(doc: BehaviourDoc, params: Record<string, unknown>, enabled: boolean): { plan: Plan; error: string | null } {
  const [plan, setPlan] = useState<Plan>(EMPTY_PLAN);
  const [error, setError] = useState<string | null>(null);
  const paramsKey = JSON.stringify(params);
  useEffect(() => {
    if (!enabled) return;
    let current = true;
    const timer = window.setTimeout(() => {
      behaviourApi.plan(doc, JSON.parse(paramsKey) as Record<string, unknown>)
        .then((p) => { if (current) { setPlan(p); setError(null); } })
        .catch((e: unknown) => { if (current) setError(issuesOf(e).message); });
    }, PLAN_DEBOUNCE_MS);
    return () => { current = false; window.clearTimeout(timer); };
  }, [doc, paramsKey, enabled]);
  return { plan, error };
}
