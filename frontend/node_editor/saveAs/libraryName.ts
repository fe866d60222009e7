// Names of files in the robot's library, checked as the server checks them (backend/engine/library.py,
// `_NAME`): letters, digits, '_', '-' or '.', not starting with '-' or '.', at most 80 characters.
const NAME = /^[A-Za-z0-9_][A-Za-z0-9_.-]{0,79}$/;

/** The name as the library stores it: the server drops a trailing ".json". */
export const libraryName = (typed: string): string => typed.trim().replace(/\.json$/, "");

/** Why `typed` cannot name a library file, or null when it can. */
export function nameProblem(typed: string): string | null {
  const t = typed.trim();
  if (!t) return "type a name";
  if (t.length > 80) return "at most 80 characters";
  if (!NAME.test(t)) return /^[-.]/.test(t) ? "start with a letter, a digit or _" : "use letters, digits, _ - or . only (no spaces)";
  return null;
}

/** A file name suggested from a program's title (other characters become _). */
export const suggestedName = (title: string | null | undefined): string =>
  (title ?? "program").replace(/[^A-Za-z0-9_.-]+/g, "_").replace(/^[-.]+/, "").slice(0, 80) || "program";
