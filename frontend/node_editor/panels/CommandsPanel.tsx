// One-click commands: the robot's postures, the library's clips (played on the program's clip player),
// a line of speech, a reset.
import type { Command } from "../api";
import { useActions, useEditor } from "../store/EditorStore";

export function CommandsPanel() {
  const { robot, clips, history } = useEditor().state;
  const { sendCommand } = useActions();
  // the program's clip player; with none, the server names what is missing
  const player = history.present.nodes.find((n) => n.data.type === "clip_player")?.id;
  const playClip = (clip: string): Command => ({ type: "play_clip", clip, ...(player ? { node: player } : {}) });
  return (
    <div className="buttons">
      {(robot?.postures ?? []).map((p) => <button key={p} onClick={() => sendCommand({ type: "go_posture", posture: p })}>{p}</button>)}
      {clips.map((c) => <button key={c} onClick={() => sendCommand(playClip(c))}>▶ {c}</button>)}
      <button onClick={() => sendCommand({ type: "say", text: "Hello!" })}>say hello</button>
      <button onClick={() => sendCommand({ type: "reset" })}>reset</button>
    </div>
  );
}
