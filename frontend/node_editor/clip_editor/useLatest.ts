// A ref that always holds the newest value of a render, for timers and listeners set up once: it is
// written after render (a layout effect), never during it.
import { useLayoutEffect, useRef, type RefObject } from "react";

export function useLatest<T>(value: T): RefObject<T> {
  const ref = useRef(value);
  useLayoutEffect(() => { ref.current = value; });
  return ref;
}
