// The 3D Pre-Viz (the server's viser page) with its ghost toggle (the stage-1 pose). Embedded, the page
// is asked (`?embed=1`) to hide viser's own control panel and notices, which would cover the robot; it
// can be enlarged over the graph, or popped out into its own window (with viser's panel). Its scene's
// background follows the editor's theme; its sound switch plays the robot's speech and sounds.
import { useEffect, useState } from "react";
import { api, withToken } from "../api";
import { SoundToggle } from "../audio/SoundToggle";
import { useActions, useEditor } from "../store/EditorStore";
import { useTheme } from "../theme";

/** The popped-out Pre-Viz window's size. */
const POPOUT_FEATURES = "width=1100,height=800";

/** The Pre-Viz URL with `embed=1` added to its query. */
export function embedUrl(url: string): string {
  return url + (url.includes("?") ? "&" : "?") + "embed=1";
}

export function PrevizPanel() {
  const { previz } = useEditor().state;
  const { setGhost } = useActions();
  const [big, setBig] = useState(false);
  const url = previz?.url ? withToken(previz.url) : null;
  const theme = useTheme();
  useEffect(() => {
    // a server without a Pre-Viz (or from before the route) refuses: the scene keeps its own colours
    if (previz?.url) api.previzTheme(theme).catch(() => undefined);
  }, [theme, previz?.url]);
  useEffect(() => {  // Esc puts the enlarged Pre-Viz back in its corner
    if (!big) return;
    const onKey = (e: KeyboardEvent) => { if (e.key === "Escape") setBig(false); };
    window.addEventListener("keydown", onKey);
    return () => window.removeEventListener("keydown", onKey);
  }, [big]);
  return (
    <div className={`previz-box ${big ? "previz-big" : ""}`} data-testid="previz-box">
      <div className="previz-head">
        <span>Pre-Viz</span>
        <span className="previz-tools">
          <label><input type="checkbox" checked={previz?.ghost ?? false} disabled={url === null}
                        onChange={(e) => setGhost(e.target.checked)} /> ghost</label>
          <SoundToggle />
          <button type="button" data-testid="previz-enlarge" aria-pressed={big} title={big ? "back to the corner (Esc)" : "enlarge over the graph"}
                  onClick={() => setBig(!big)}>{big ? "⤡ shrink" : "⤢ enlarge"}</button>
          <button type="button" data-testid="previz-popout" disabled={url === null} title="open the Pre-Viz in its own window"
                  onClick={() => url && window.open(url, "nutty-previz", POPOUT_FEATURES)}>↗ pop out</button>
        </span>
      </div>
      {url ? <iframe title="Pre-Viz" src={embedUrl(url)} /> : <div className="muted pad">Pre-Viz disabled on this server.</div>}
    </div>
  );
}
