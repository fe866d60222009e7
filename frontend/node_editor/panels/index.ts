// Every panel of the editor, and where the layout shows it. A panel is a component that reads the
// store (`useEditor`), the actions (`useActions`) and, if live, telemetry (../context): adding one is
// one file and one line here.
import type { ComponentType } from "react";
import { CommandsPanel } from "./CommandsPanel";
import { ConsolePanel } from "./ConsolePanel";
import { CurvePanel } from "./CurvePanel";
import { InputsPanel } from "./InputsPanel";
import { Palette } from "./Palette";
import { ParamPanel } from "./ParamPanel";
import { PrevizPanel } from "./PrevizPanel";
import { ProgramInfoPanel } from "./ProgramInfoPanel";
import { SubgraphInfo } from "./SubgraphInfo";
import { SubgraphLibrary } from "./SubgraphLibrary";

/** Places in the layout (../Layout.tsx): the side bars, the Pre-Viz corner and the live column's rows. */
export type Area = "left" | "right" | "previz" | "live" | "controls" | "log";

export interface Panel {
  id: string;
  area: Area;
  Component: ComponentType;
}

export const PANELS: Panel[] = [
  { id: "palette", area: "left", Component: Palette },
  { id: "subgraphs", area: "left", Component: SubgraphLibrary },
  { id: "params", area: "right", Component: ParamPanel },
  { id: "subgraph-info", area: "right", Component: SubgraphInfo },
  { id: "previz", area: "previz", Component: PrevizPanel },
  { id: "curves", area: "live", Component: CurvePanel },
  { id: "inputs", area: "controls", Component: InputsPanel },
  { id: "commands", area: "controls", Component: CommandsPanel },
  { id: "program-info", area: "controls", Component: ProgramInfoPanel },
  { id: "console", area: "log", Component: ConsolePanel },
];
