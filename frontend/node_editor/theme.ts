// The editor's colour theme, light or dark: chosen in the top bar, kept in localStorage, and at first
// following the system's preference (prefers-color-scheme). The page's root carries it as
// `data-theme` (theme-light.css restyles the editor under it); the Pre-Viz follows it too (PrevizPanel).
import { useSyncExternalStore } from "react";

export type Theme = "light" | "dark";

const KEY = "nutty.theme";
const listeners = new Set<() => void>();

function stored(): Theme | null {
  try {
    const t = localStorage.getItem(KEY);
    return t === "light" || t === "dark" ? t : null;
  } catch {
    return null;  // storage blocked (a private window's policy): the system's preference then
  }
}

function systemTheme(): Theme {
  return typeof matchMedia === "function" && matchMedia("(prefers-color-scheme: light)").matches ? "light" : "dark";
}

let current: Theme = stored() ?? systemTheme();

/** Mark the page with the current theme (before the first render, so it never flashes the other one). */
export function applyTheme(): void {
  document.documentElement.dataset.theme = current;
  document.documentElement.style.colorScheme = current;
}

export function currentTheme(): Theme {
  return current;
}

export function setTheme(theme: Theme): void {
  current = theme;
  try { localStorage.setItem(KEY, theme); } catch { /* kept for this page only */ }
  applyTheme();
  for (const l of listeners) l();
}

function subscribe(listener: () => void): () => void {
  listeners.add(listener);
  return () => { listeners.delete(listener); };
}

/** The theme, re-rendering on a change. */
export function useTheme(): Theme {
  return useSyncExternalStore(subscribe, currentTheme);
}
