// The editor's page: the top bar, the graph (or, by tab, the clip library or the clip editor), and the
// registered panels in their areas. The side bars and the bottom panels fold away (their toggle) and
// resize (drag their inner edge); the page remembers both.
import { useCallback, useEffect, useState, type CSSProperties, type PointerEvent as ReactPointerEvent } from "react";
import { BehaviourBrowser } from "./behaviour_editor/BehaviourBrowser";
import { BehaviourEditor } from "./behaviour_editor/BehaviourEditor";
import { ClipBrowser } from "./clip_editor/ClipBrowser";
import { ClipEditor } from "./clip_editor/ClipEditor";
import { GraphView } from "./GraphView";
import { PANELS, type Area } from "./panels";
import { useEditor } from "./store/EditorStore";
import { Toolbar } from "./Toolbar";

/** Where the page keeps its panels' sizes between visits (localStorage). */
const STORAGE_KEY = "nutty.layout/1";
/** A folded side bar keeps this much (px) for its toggle. */
const FOLDED_SIDE = 24;
/** Sizes (px) a side bar or the bottom panels can be dragged to. */
const SIDE_RANGE = { min: 160, max: 520 };
const BOTTOM_RANGE = { min: 160, max: 640 };

type Side = "left" | "right" | "bottom";
interface Fold { open: boolean; size: number | null }
type Prefs = Record<Side, Fold>;

const DEFAULTS: Prefs = { left: { open: true, size: null }, right: { open: true, size: null }, bottom: { open: true, size: null } };

function loadPrefs(): Prefs {
  try {
    const saved = JSON.parse(window.localStorage.getItem(STORAGE_KEY) ?? "{}") as Partial<Prefs>;
    return { left: { ...DEFAULTS.left, ...saved.left }, right: { ...DEFAULTS.right, ...saved.right }, bottom: { ...DEFAULTS.bottom, ...saved.bottom } };
  } catch {
    return DEFAULTS;  // unreadable (or no storage): the default layout
  }
}

function PanelsIn({ area }: { area: Area }) {
  return <>{PANELS.filter((p) => p.area === area).map(({ id, Component }) => <Component key={id} />)}</>;
}

const LABELS: Record<Side, string> = { left: "Blocks", right: "Parameters", bottom: "Pre-Viz · curves · controls" };

function Toggle({ side, open, flip }: { side: Side; open: boolean; flip: () => void }) {
  const arrow = { left: open ? "◀" : "▶", right: open ? "▶" : "◀", bottom: open ? "▼" : "▲" }[side];
  return (
    <button className="panel-toggle" data-testid={`toggle-${side}`} onClick={flip} aria-expanded={open}
            title={open ? `Fold the ${LABELS[side]} away` : `Show the ${LABELS[side]}`}>
      <span>{LABELS[side]}</span><span aria-hidden>{arrow}</span>
    </button>
  );
}

/** A drag handle on a panel's inner edge: sets its size in px (folding nothing). */
function Resizer({ side, resize }: { side: Side; resize: (side: Side, size: number) => void }) {
  const start = (e: ReactPointerEvent) => {
    e.preventDefault();
    const panel = (e.currentTarget.parentElement as HTMLElement).getBoundingClientRect();
    const move = (ev: PointerEvent) => resize(side, side === "left" ? ev.clientX - panel.left
      : side === "right" ? panel.right - ev.clientX : panel.bottom - ev.clientY);
    const up = () => { window.removeEventListener("pointermove", move); window.removeEventListener("pointerup", up); };
    window.addEventListener("pointermove", move);
    window.addEventListener("pointerup", up);
  };
  return <div className="panel-resize" data-testid={`resize-${side}`} onPointerDown={start} />;
}

/** The graph's area: a tab strip "Program | Clips | Clip: <name> | Behaviours | Behaviour: <name>" over
 * the program's graph, the clip library, the open clip's editor, the behaviour library and the open
 * behaviour's editor. The graph stays mounted (hidden) so its view is kept. */
function GraphArea() {
  const { state, dispatch } = useEditor();
  const { clip, clipTab, behaviour } = state;
  const show = (tab: typeof clipTab) => () => dispatch({ type: "clipTabShown", tab });
  const pane = (tab: typeof clipTab) => (clipTab === tab ? "" : "pane-hidden");
  // the deep link /?clip=<name> opens that clip at load; the address then follows the open clip
  useEffect(() => {
    const name = new URLSearchParams(location.search).get("clip");
    if (name) dispatch({ type: "clipRequested", name });
    // and /?behaviour=<name> that behaviour
    const behaviourName = new URLSearchParams(location.search).get("behaviour");
    if (behaviourName) dispatch({ type: "behaviourRequested", name: behaviourName });
  }, [dispatch]);
  const openName = clip && !clip.fresh ? clip.name : null;
  useEffect(() => {
    const url = new URL(location.href);
    if ((url.searchParams.get("clip") ?? null) === openName) return;
    if (openName) url.searchParams.set("clip", openName);
    else url.searchParams.delete("clip");
    history.replaceState(history.state, "", url.toString());
  }, [openName]);
  const openBehaviour = behaviour && !behaviour.fresh ? behaviour.name : null;
  useEffect(() => {
    const url = new URL(location.href);
    if ((url.searchParams.get("behaviour") ?? null) === openBehaviour) return;
    if (openBehaviour) url.searchParams.set("behaviour", openBehaviour);
    else url.searchParams.delete("behaviour");
    history.replaceState(history.state, "", url.toString());
  }, [openBehaviour]);
  return (
    <div className="graph-area">
      <nav className="graph-tabs" role="tablist">
        <button role="tab" data-testid="tab-program" className={clipTab === "program" ? "on" : ""} aria-selected={clipTab === "program"}
                onClick={show("program")}>Program</button>
        <button role="tab" data-testid="tab-clips" className={clipTab === "library" ? "on" : ""} aria-selected={clipTab === "library"}
                onClick={show("library")}>Clips</button>
        {clip && <>
          <button role="tab" data-testid="tab-clip" className={clipTab === "clip" ? "on" : ""} aria-selected={clipTab === "clip"}
                  onClick={show("clip")}>Clip: {clip.name}</button>
          <button className="tab-close" data-testid="tab-clip-close" aria-label={`close the clip ${clip.name}`}
                  onClick={() => dispatch({ type: "clipCloseRequested" })}>×</button>
        </>}
        <button role="tab" data-testid="tab-behaviours" className={clipTab === "behaviours" ? "on" : ""} aria-selected={clipTab === "behaviours"}
                onClick={show("behaviours")}>Behaviours</button>
        {behaviour && <>
          <button role="tab" data-testid="tab-behaviour" className={clipTab === "behaviour" ? "on" : ""} aria-selected={clipTab === "behaviour"}
                  onClick={show("behaviour")}>Behaviour: {behaviour.name}</button>
          <button className="tab-close" data-testid="tab-behaviour-close" aria-label={`close the behaviour ${behaviour.name}`}
                  onClick={() => dispatch({ type: "behaviourCloseRequested" })}>×</button>
        </>}
      </nav>
      <div className="graph-panes">
        <div className={pane("program")}><GraphView /></div>
        {clipTab === "library" && <ClipBrowser />}
        {clip && <div className={pane("clip")}><ClipEditor active={clipTab === "clip"} /></div>}
        {clipTab === "behaviours" && <BehaviourBrowser />}
        {behaviour && <div className={pane("behaviour")}><BehaviourEditor active={clipTab === "behaviour"} /></div>}
      </div>
    </div>
  );
}

export function Layout() {
  const [prefs, setPrefs] = useState<Prefs>(loadPrefs);
  useEffect(() => {
    try { window.localStorage.setItem(STORAGE_KEY, JSON.stringify(prefs)); } catch { /* no storage: not remembered */ }
  }, [prefs]);
  const flip = useCallback((side: Side) => setPrefs((p) => ({ ...p, [side]: { ...p[side], open: !p[side].open } })), []);
  const resize = useCallback((side: Side, size: number) => {
    const { min, max } = side === "bottom" ? BOTTOM_RANGE : SIDE_RANGE;
    setPrefs((p) => ({ ...p, [side]: { open: true, size: Math.round(Math.min(max, Math.max(min, size))) } }));
  }, []);
  const width = (side: "left" | "right") => (!prefs[side].open ? `${FOLDED_SIDE}px` : prefs[side].size ? `${prefs[side].size}px` : undefined);
  const style = {
    ...(width("left") ? { "--left-now": width("left") } : {}),
    ...(width("right") ? { "--right-now": width("right") } : {}),
  } as CSSProperties;
  // until dragged, the bottom panels are as tall as their content (the console keeps several lines)
  const bottomStyle = prefs.bottom.open && prefs.bottom.size ? { height: prefs.bottom.size, minHeight: 0 } : undefined;
  const closed = (["left", "right", "bottom"] as const).filter((s) => !prefs[s].open).map((s) => `${s}-closed`).join(" ");
  return (
    <div className={`app ${closed}`} style={style}>
      <Toolbar />
      <aside className="left">
        <Toggle side="left" open={prefs.left.open} flip={() => flip("left")} />
        <PanelsIn area="left" />
        {prefs.left.open && <Resizer side="left" resize={resize} />}
      </aside>
      <GraphArea />
      <aside className="right">
        <Toggle side="right" open={prefs.right.open} flip={() => flip("right")} />
        <PanelsIn area="right" />
        {prefs.right.open && <Resizer side="right" resize={resize} />}
      </aside>
      <section className="bottom" style={bottomStyle}>
        <Toggle side="bottom" open={prefs.bottom.open} flip={() => flip("bottom")} />
        {prefs.bottom.open && <Resizer side="bottom" resize={resize} />}
        <div className="previz"><PanelsIn area="previz" /></div>
        <div className="livecol">
          <PanelsIn area="live" />
          <div className="controls-strip" data-testid="controls"><PanelsIn area="controls" /></div>
          <PanelsIn area="log" />
        </div>
      </section>
    </div>
  );
}
