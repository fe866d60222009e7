// Undo/redo over immutable snapshots of the graph (past, present, future).
export interface History<T> {
  past: T[];
  present: T;
  future: T[];
}

export const LIMIT = 200;

export function init<T>(present: T): History<T> {
  return { past: [], present, future: [] };
}

/** Record a new state; identical states are not recorded, and redo history is dropped. */
export function push<T>(h: History<T>, next: T, same: (a: T, b: T) => boolean = (a, b) => a === b): History<T> {
  if (same(h.present, next)) return h;
  const past = [...h.past, h.present];
  if (past.length > LIMIT) past.shift();
  return { past, present: next, future: [] };
}

/** Replace the present without a history entry (e.g. live values, selection). */
export function replace<T>(h: History<T>, next: T): History<T> {
  return { ...h, present: next };
}

export function undo<T>(h: History<T>): History<T> {
  if (!h.past.length) return h;
  const prev = h.past[h.past.length - 1];
  return { past: h.past.slice(0, -1), present: prev, future: [h.present, ...h.future] };
}

export function redo<T>(h: History<T>): History<T> {
  if (!h.future.length) return h;
  const [next, ...rest] = h.future;
  return { past: [...h.past, h.present], present: next, future: rest };
}
