import { createContext } from "react";
import type { BlockEntry } from "./api";

export interface LayerState {
  name: string;
  mode: string;
  weight: number;
  fade: number;
  effective: number;
  active: boolean;
}

export interface Live {
  values: Record<string, unknown>;
  history: Record<string, number[]>;
  layers: Record<string, LayerState[]>;
  /** Fade a mixer's layer in or out (a set_layer command). */
  setLayer?: (mixer: string, layer: string, active: boolean) => void;
}

export const CatalogContext = createContext<Record<string, BlockEntry>>({});
export const LiveContext = createContext<Live>({ values: {}, history: {}, layers: {} });
