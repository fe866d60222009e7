// Contexts the graph's blocks and the live panels read: the block catalog, and telemetry (kept apart
// from the store, so 30 messages a second re-render only what shows them).
import { createContext } from "react";
import type { Catalog } from "./api";
import { emptyLive, emptySamples, type Live, type Samples } from "./telemetry";

export interface LiveWithActions extends Live {
  /** Fade a mixer's layer in or out (a set_layer command). */
  setLayer?: (mixer: string, layer: string, active: boolean) => void;
}

export const CatalogContext = createContext<Catalog>({});
export const LiveContext = createContext<LiveWithActions>(emptyLive);
export const SamplesContext = createContext<Samples>(emptySamples);
