// The telemetry WebSocket: subscribes to every output of the graph (again when the outputs change),
// reconnects when the server goes away, and accumulates values and frames (../telemetry).
import { useEffect, useMemo, useRef, useState } from "react";
import { wsUrl, type SignalRef, type TelemetryMessage } from "../api";
import { onTelemetry } from "../audio/liveAudio";
import type { FlowNode } from "../graph";
import { emptyLive, emptySamples, nextLive, nextSamples, subscription } from "../telemetry";

const RECONNECT_MS = 1000;

/** Every output port of the graph, as a stable list while the set of outputs stays the same. */
export function useSignals(nodes: FlowNode[]): SignalRef[] {
  const key = nodes.map((n) => `${n.id}:${Object.keys(n.data.outputs).join(",")}`).join(";");
  return useMemo(() => nodes.flatMap((n) => Object.keys(n.data.outputs).map((port) => ({ node: n.id, port }))),
    [key]);  // eslint-disable-line react-hooks/exhaustive-deps -- `key` stands for the outputs of `nodes`: a moved block keeps the list
}

export function useTelemetry(signals: SignalRef[]) {
  const [live, setLive] = useState(emptyLive);
  const [samples, setSamples] = useState(emptySamples);
  const socket = useRef<WebSocket | null>(null);
  const wanted = useRef(signals);  // what a (re)connected socket subscribes to

  useEffect(() => {
    let closed = false;
    const connect = () => {
      const ws = new WebSocket(wsUrl("/ws/telemetry"));
      socket.current = ws;
      ws.onopen = () => ws.send(JSON.stringify(subscription(wanted.current)));
      ws.onmessage = (ev) => {
        const msg = JSON.parse(ev.data) as TelemetryMessage;
        if (msg.type !== "telemetry") return;
        if (msg.frame) onTelemetry(msg.t, msg.events);  // the robot's speech and sounds, heard in step
        setLive((prev) => nextLive(prev, msg));
        if (msg.frame) setSamples((prev) => nextSamples(prev, msg));
      };
      ws.onclose = () => { if (!closed) window.setTimeout(connect, RECONNECT_MS); };
    };
    connect();
    return () => { closed = true; socket.current?.close(); };
  }, []);

  useEffect(() => {
    wanted.current = signals;
    const ws = socket.current;
    if (ws && ws.readyState === WebSocket.OPEN) ws.send(JSON.stringify(subscription(signals)));
  }, [signals]);

  return { live, samples };
}
