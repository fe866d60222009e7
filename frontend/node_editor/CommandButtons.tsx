// The top bar's end: the theme toggle and the shortcut list's button ("?"), and the command overlays
// (the find-block box, the shortcut list) when one is open; it hands the block menu's bypass entry the store.
import { useBypassMenu } from "./bypassMenu";
import { FindBlock } from "./FindBlock";
import { ShortcutHelp } from "./ShortcutHelp";
import { useEditor } from "./store/EditorStore";
import { setTheme, useTheme } from "./theme";

export function CommandButtons() {
  const { state, dispatch } = useEditor();
  const theme = useTheme();
  useBypassMenu();
  const other = theme === "dark" ? "light" : "dark";
  return (
    <>
      <button className="icon" data-testid="theme-toggle" onClick={() => setTheme(other)} aria-label={`${other} theme`}
              title={`switch to the ${other} theme`}>{theme === "dark" ? "☀" : "☾"}</button>
      <button className="icon" data-testid="shortcuts" aria-pressed={state.overlay === "help"} title="keyboard shortcuts (?)"
              onClick={() => dispatch({ type: "overlayShown", overlay: state.overlay === "help" ? null : "help" })}>?</button>
      {state.overlay === "find" && <FindBlock />}
      {state.overlay === "help" && <ShortcutHelp />}
    </>
  );
}
