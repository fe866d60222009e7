// What the robot has, for the inspector's selects and new items' defaults: its clips, postures and
// sounds (asked once per editor), the running program's exposed inputs and the face expressions (the
// options of its display DoFs, from the store).
import { useEffect, useMemo, useState } from "react";
import { useEditor } from "../store/EditorStore";
import { behaviourApi } from "./behaviourApi";
import type { RobotNames } from "./ItemInspector";
import type { ItemDefaults } from "./model/edits";

export function useRobotNames(): { names: RobotNames; defaults: ItemDefaults } {
  const { state } = useEditor();
  const [clips, setClips] = useState<string[]>([]);
  const [postures, setPostures] = useState<string[]>([]);
  const [sounds, setSounds] = useState<string[]>([]);
  useEffect(() => {
    behaviourApi.clips().then(setClips).catch(() => undefined);
    behaviourApi.postures().then(setPostures).catch(() => undefined);
    behaviourApi.sounds().then((s) => setSounds(s.map((x) => x.name))).catch(() => undefined);
  }, []);
  const inputs = useMemo(() => state.inputs.decls.map((d) => d.name), [state.inputs.decls]);
  const expressions = useMemo(() => {
    const dofs = state.robot?.dofs ?? [];
    return [...new Set(dofs.filter((d) => d.type === "enum" && d.dimension === "display").flatMap((d) => d.options ?? []))];
  }, [state.robot]);
  const names = useMemo(() => ({ clips, postures, sounds, inputs, expressions }), [clips, postures, sounds, inputs, expressions]);
  const defaults = useMemo<ItemDefaults>(() => ({
    clip: clips[0], posture: postures[0], sound: sounds[0], input: inputs[0],
    expression: expressions.find((e) => e !== "neutral") ?? expressions[0],
  }), [clips, postures, sounds, inputs, expressions]);
  return { names, defaults };
}
