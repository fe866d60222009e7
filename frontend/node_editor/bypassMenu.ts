// A block's context menu offers bypass (like M): the entry is registered once with the canvas's menus;
// the store it acts on is handed over by the hook the editor mounts (useBypassMenu).
import { useEffect } from "react";
import type { Catalog } from "./api";
import { nodeMenuExtras } from "./canvasMenus";
import { bypassable } from "./store/editCommands";
import { useEditor } from "./store/EditorStore";
import type { Action } from "./store/state";

const store: { dispatch: ((a: Action) => void) | null; catalog: Catalog } = { dispatch: null, catalog: {} };

nodeMenuExtras.push(
  { label: "Bypass (M)", when: (n) => n.type === "block" && !n.data.bypass && bypassable(store.catalog[n.data.type]),
    run: (n) => store.dispatch?.({ type: "bypassToggled", nodes: [n.id] }) },
  { label: "Stop bypassing (M)", when: (n) => n.type === "block" && n.data.bypass === true,
    run: (n) => store.dispatch?.({ type: "bypassToggled", nodes: [n.id] }) },
);

/** Hands the menu entry the store (mounted once, under the store's provider). */
export function useBypassMenu(): void {
  const { state, dispatch } = useEditor();
  useEffect(() => {
    store.dispatch = dispatch;
    store.catalog = state.catalog;
  }, [dispatch, state.catalog]);
}
