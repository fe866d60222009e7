// The 3D Pre-Viz (the server's viser page) with its ghost toggle (the stage-1 pose).
import { withToken } from "../api";
import { useActions, useEditor } from "../store/EditorStore";

export function PrevizPanel() {
  const { previz } = useEditor().state;
  const { setGhost } = useActions();
  const url = previz?.url ? withToken(previz.url) : null;
  return (
    <>
      <div className="previz-head">
        <span>Pre-Viz</span>
        <label><input type="checkbox" checked={previz?.ghost ?? false} disabled={url === null}
                      onChange={(e) => setGhost(e.target.checked)} /> ghost</label>
      </div>
      {url ? <iframe title="Pre-Viz" src={url} /> : <div className="muted pad">Pre-Viz disabled on this server.</div>}
    </>
  );
}
