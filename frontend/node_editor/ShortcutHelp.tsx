// The shortcut list ("?"): every key of the editor, from the one table the handlers read (./shortcuts).
// Escape, a click beside it or "?" again closes it.
import { useEffect } from "react";
import { keyLabel, SHORTCUTS } from "./shortcuts";
import { useEditor } from "./store/EditorStore";

const WHERE = { anywhere: "Anywhere", canvas: "Over the canvas" } as const;

export function ShortcutHelp() {
  const { dispatch } = useEditor();
  const close = () => dispatch({ type: "overlayShown", overlay: null });
  useEffect(() => {
    const onKey = (e: KeyboardEvent) => { if (e.key === "Escape") dispatch({ type: "overlayShown", overlay: null }); };
    window.addEventListener("keydown", onKey);
    return () => window.removeEventListener("keydown", onKey);
  }, [dispatch]);
  return (
    <div className="modal-backdrop" onClick={close} data-testid="shortcut-help">
      <div className="modal shortcut-help" role="dialog" aria-label="keyboard shortcuts" onClick={(e) => e.stopPropagation()}>
        <h3>Keyboard shortcuts</h3>
        {(["canvas", "anywhere"] as const).map((scope) => (
          <section key={scope}>
            <div className="group-title">{WHERE[scope]}</div>
            <table>
              <tbody>
                {SHORTCUTS.filter((s) => s.scope === scope).map((s) => (
                  <tr key={s.id} data-testid={`shortcut-row-${s.id}`}>
                    <td className="keys">{s.keys.map((k) => <kbd key={k}>{keyLabel(k)}</kbd>)}</td>
                    <td>{s.what}</td>
                  </tr>
                ))}
              </tbody>
            </table>
          </section>
        ))}
        <div className="modal-buttons"><button onClick={close} autoFocus>Close (?)</button></div>
      </div>
    </div>
  );
}
