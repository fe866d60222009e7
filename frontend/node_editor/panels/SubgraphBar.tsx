// Over the canvas: where you are ("program › idle", click to go back), and the organising tools —
// group the selected blocks into a subgraph (Ctrl+G, with a dialog choosing the exposed ports), open
// a subgraph node, save a subgraph to the robot's library, and add a comment frame.
import { useReactFlow } from "@xyflow/react";
import { useCallback, useEffect, useMemo, useState } from "react";
import { api, ApiError } from "../api";
import { FALLBACK_CANVAS_SIZE } from "../layout/constants";
import { useActions, useEditor } from "../store/EditorStore";
import { requestSaveAs } from "../saveAs/saveAsRequest";
import {
  breadcrumb, exposedCandidates, frameAround, groupCandidates, openDefinition, selectedBlocks, SUBGRAPH, type Candidate, type SubgraphDef,
} from "../subgraphs";

/** A new comment frame (none selected) goes a third of the way into the visible canvas, both ways. */
const NEW_COMMENT_PARTS = 3;

/** Sent on `window` when the library's subgraphs change (the palette lists them again). */
export const SUBGRAPHS_CHANGED = "nutty:subgraphs-changed";

/** The ports dialog: grouping (a name, wired ports locked on) or editing an open subgraph's ports
 * (`editing`: its description instead of a name). */
function GroupDialog({ candidates, onGroup, onCancel, editing }: {
  candidates: Candidate[]; onGroup: (name: string, ports: Candidate[]) => void; onCancel: () => void;
  editing?: { description: string };
}) {
  const [name, setName] = useState(editing ? editing.description : "group");
  const [chosen, setChosen] = useState(() => candidates.map((c) => c.crossing || !!c.checked));
  const [names, setNames] = useState(() => candidates.map((c) => c.name));
  const row = (c: Candidate, i: number) => (
    <label key={`${c.kind}:${c.node}.${c.port}`} className={`port-choice ${c.crossing ? "wired" : ""}`}>
      <input type="checkbox" checked={chosen[i]} disabled={c.crossing} data-testid={`expose-${c.kind}-${c.node}.${c.port}`}
             onChange={(e) => setChosen(chosen.map((v, k) => (k === i ? e.target.checked : v)))} />
      <span className="port-where">{c.node}.{c.port}</span>
      <span className="port-type">{c.type}{c.crossing ? " · wired" : ""}</span>
      <input className="port-name" value={names[i]} aria-label={`exposed name of ${c.node}.${c.port}`}
             onChange={(e) => setNames(names.map((v, k) => (k === i ? e.target.value : v)))} />
    </label>
  );
  const submit = () => onGroup(name.trim(), candidates.flatMap((c, i) => (chosen[i] ? [{ ...c, name: names[i].trim() || c.name }] : [])));
  return (
    <div className="modal-backdrop" onMouseDown={onCancel}>
      <div className="modal group-dialog" role="dialog" aria-label="group into a block" data-testid="group-dialog"
           onMouseDown={(e) => e.stopPropagation()}>
        <h3>{editing ? "Ports of the subgraph" : "Group into a block"}</h3>
        <label className="field"><span className="field-name">{editing ? "Description" : "Name"}</span>
          <input autoFocus value={name} data-testid="group-name" onChange={(e) => setName(e.target.value)}
                 onKeyDown={(e) => e.key === "Enter" && submit()} /></label>
        <p className="muted">{editing
          ? "Ports the subgraph's nodes show. Wires to a port no longer exposed are cut; a renamed port keeps its wires."
          : "Ports the new block shows. Wired ports (a wire crosses the selection's edge) are always exposed."}</p>
        {(["input", "output"] as const).map((kind) => (
          <div key={kind} className="port-list">
            <div className="group-title">{kind === "input" ? "Inputs" : "Outputs"}</div>
            {candidates.map((c, i) => (c.kind === kind ? row(c, i) : null))}
          </div>
        ))}
        <div className="modal-buttons">
          <button onClick={onCancel}>Cancel</button>
          <button className="primary" data-testid="group-confirm" onClick={submit}>{editing ? "Apply" : "Group"}</button>
        </div>
      </div>
    </div>
  );
}

export function SubgraphBar() {
  const { state, dispatch } = useEditor();
  const { say } = useActions();
  const flow = useReactFlow();
  const graph = state.history.present;
  const meta = state.meta;
  const crumbs = useMemo(() => breadcrumb(meta), [meta]);
  const blocks = selectedBlocks(graph);
  const selectedSubgraph = blocks.length === 1 && blocks[0].data.type === SUBGRAPH ? blocks[0] : null;
  const [grouping, setGrouping] = useState<Candidate[] | null>(null);
  const [editingPorts, setEditingPorts] = useState<Candidate[] | null>(null);

  const startGrouping = useCallback(() => {
    const ids = selectedBlocks(graph).map((n) => n.id);
    if (ids.length < 1) { say("select the blocks to group first (Shift+click or drag a box)"); return; }
    setGrouping(groupCandidates(graph, ids));
  }, [graph, say]);

  useEffect(() => {
    const onKey = (e: KeyboardEvent) => {
      const t = e.target as HTMLElement | null;
      if (t && ["INPUT", "TEXTAREA", "SELECT"].includes(t.tagName)) return;
      if ((e.ctrlKey || e.metaKey) && e.key.toLowerCase() === "g") { e.preventDefault(); startGrouping(); }
    };
    window.addEventListener("keydown", onKey);
    return () => window.removeEventListener("keydown", onKey);
  }, [startGrouping]);

  const toLibrary = useMemo((): { name: string; definition: SubgraphDef } | null => {
    if (selectedSubgraph && meta) {
      const name = String(selectedSubgraph.data.params.subgraph);
      const def = (meta.subgraphs ?? {})[name] as SubgraphDef | undefined;
      return def ? { name, definition: def } : null;
    }
    return openDefinition(graph, meta);
  }, [selectedSubgraph, graph, meta]);

  const saveToLibrary = useCallback(async () => {
    if (!toLibrary) return;
    const definition = toLibrary.definition;
    const existing = await api.subgraphs().catch(() => [] as string[]);
    requestSaveAs(toLibrary.name, { what: "subgraph", existing, save: async (name) => {
      try {
        await api.saveSubgraph(name, definition);
        window.dispatchEvent(new Event(SUBGRAPHS_CHANGED));
        say(`saved subgraph '${name}' to the library`);
      } catch (e) {
        const report = e instanceof ApiError ? e.detail?.report : null;
        say(`not saved: ${report?.errors?.[0]?.message ?? (e instanceof ApiError ? e.detail?.message : String(e))}`);
      }
    } });
  }, [toLibrary, say]);

  const addComment = useCallback(() => {
    const box = document.querySelector(".graph")?.getBoundingClientRect();
    const centre = flow.screenToFlowPosition({
      x: (box?.left ?? 0) + (box?.width ?? FALLBACK_CANVAS_SIZE.width) / NEW_COMMENT_PARTS,
      y: (box?.top ?? 0) + (box?.height ?? FALLBACK_CANVAS_SIZE.height) / NEW_COMMENT_PARTS,
    });
    dispatch({ type: "commentAdded", ...frameAround(graph, centre) });
  }, [flow, graph, dispatch]);

  return (
    <div className="subgraph-bar" data-testid="subgraph-bar">
      <nav className="crumbs" aria-label="where you are" data-testid="breadcrumb">
        {crumbs.map((c, i) => (
          <span key={i}>
            {i > 0 && <span className="sep"> › </span>}
            {c.levels > 0
              ? <button className="crumb" data-testid={`crumb-${i}`} onClick={() => dispatch({ type: "subgraphClosed", levels: c.levels })}>{c.label}</button>
              : <span className="crumb here">{c.label}</span>}
          </span>
        ))}
      </nav>
      <button onClick={startGrouping} disabled={blocks.length < 2} data-testid="group" title="Ctrl+G">Group into a block</button>
      {selectedSubgraph && <button data-testid="open-subgraph" onClick={() => dispatch({ type: "subgraphOpened", node: selectedSubgraph.id })}>Open</button>}
      {toLibrary && <button data-testid="save-subgraph" onClick={saveToLibrary} title="reuse it in other programs">Save '{toLibrary.name}' to library</button>}
      {meta?.inside && <button data-testid="edit-ports" onClick={() => setEditingPorts(exposedCandidates(graph, meta))}
                               title="choose the ports the subgraph shows">Ports…</button>}
      <button data-testid="add-comment" onClick={addComment} title="a frame around the selected blocks">Comment</button>
      {editingPorts && meta?.inside && (
        <GroupDialog candidates={editingPorts} editing={{ description: meta.inside.description }} onCancel={() => setEditingPorts(null)}
                     onGroup={(description, ports) => { setEditingPorts(null); dispatch({ type: "exposedEdited", ports, description }); }} />
      )}
      {grouping && (
        <GroupDialog candidates={grouping} onCancel={() => setGrouping(null)}
                     onGroup={(name, ports) => { setGrouping(null); dispatch({ type: "grouped", name, ports }); }} />
      )}
    </div>
  );
}
