// The inspector's start field: absolute seconds, or relative to another item (its start, end or one of
// its clip's anchors, plus an offset). Switching mode keeps the item where the plan has it.
import type { BehaviourDoc, ItemDoc, Plan, StartRef } from "./model/types";
import { isStartRef } from "./model/types";
import { allItems, dependentsOf, plannedById, roundMs } from "./model/refs";
import { CommitInput, NameSelect } from "./fieldInputs";

const num = (text: string, fallback: number) => (Number.isFinite(Number(text)) && text.trim() !== "" ? Number(text) : fallback);

export function StartEditor({ doc, plan, item, setStart }: {
  doc: BehaviourDoc; plan: Plan; item: ItemDoc; setStart: (start: number | StartRef, label: string) => void;
}) {
  const planned = plannedById(plan);
  const own = planned.get(item.id)?.start ?? (typeof item.start === "number" ? item.start : 0);
  // not itself, nor what is timed from it (that would be a cycle)
  const below = dependentsOf(doc, item.id);
  const others = allItems(doc).map((l) => l.item.id).filter((i) => i !== item.id && !below.has(i));
  const start = item.start ?? 0;

  if (!isStartRef(start)) {
    return (
      <div className="bh-start">
        <label>Start
          <select data-testid="item-field-start-mode" value="absolute" onChange={() => {
            const ref = others[0];
            if (!ref) return;
            setStart({ item: ref, at: "start", offset: roundMs(own - (planned.get(ref)?.start ?? 0)) }, "time from an item");
          }}>
            <option value="absolute">at (s)</option>
            <option value="relative" disabled={!others.length}>relative to</option>
          </select>
        </label>
        <label>Seconds
          <CommitInput testId="item-field-start" value={String(start)}
                       onCommit={(t) => setStart(Math.max(0, roundMs(num(t, start))), "start")} />
        </label>
      </div>
    );
  }

  const anchors = Object.keys(planned.get(start.item)?.anchors ?? {});
  const set = (patch: Partial<StartRef>, label: string) => {
    const next: StartRef = { ...start, ...patch };
    if (next.at !== "anchor") delete next.anchor;
    setStart(next, label);
  };
  return (
    <div className="bh-start">
      <label>Start
        <select data-testid="item-field-start-mode" value="relative"
                onChange={() => setStart(roundMs(Math.max(0, own)), "absolute start")}>
          <option value="absolute">at (s)</option>
          <option value="relative">relative to</option>
        </select>
      </label>
      <label>Item
        <NameSelect testId="item-field-start-item" value={start.item} options={others} onChange={(v) => set({ item: v }, "start item")} />
      </label>
      <label>At
        <select data-testid="item-field-start-at" value={start.at ?? "start"}
                onChange={(e) => {
                  const at = e.target.value as StartRef["at"];
                  set(at === "anchor" ? { at, anchor: start.anchor ?? anchors[0] ?? null } : { at }, "start at");
                }}>
          <option value="start">its start</option>
          <option value="end">its end</option>
          <option value="anchor">an anchor</option>
        </select>
      </label>
      {start.at === "anchor" && (
        <label>Anchor
          <NameSelect testId="item-field-start-anchor" value={start.anchor ?? ""} options={anchors}
                      onChange={(v) => set({ anchor: v }, "start anchor")} />
        </label>
      )}
      <label>Offset (s)
        <CommitInput testId="item-field-start-offset" value={String(start.offset ?? 0)}
                     onCommit={(t) => set({ offset: roundMs(num(t, start.offset ?? 0)) }, "start offset")} />
      </label>
    </div>
  );
}
