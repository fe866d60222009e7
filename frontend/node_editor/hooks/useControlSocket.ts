// The control WebSocket: commands go out on it (over REST while it is not open), and its acks, errors
// and events become console lines. It reconnects when the server goes away.
import { useCallback, useEffect, useRef } from "react";
import { api, wsUrl, type Command, type ControlMessage } from "../api";

const RECONNECT_MS = 1000;

/** A console line for a message of /ws/control. */
export function describeControlMessage(m: ControlMessage): string {
  switch (m.type) {
    case "event":
      if (m.event === "servo_fault")  // the robot stopped its show: say which servo and why
        return `servo fault: ${String(m.joint)} (servo ${String(m.servo)} on ${String(m.bus)}): ${String(m.fault)}; held, the rest of the robot went to rest`;
      if (m.event === "sim_contact") {  // the physics preview saw two links (or a link and the floor) touch
        const [a, b] = (m.links as string[] | undefined) ?? ["?", "?"];
        const depth = (1000 * Number(m.depth)).toFixed(1);
        return `contact in simulation: ${a} / ${b} at t=${Number(m.t).toFixed(2)} s, ${depth} mm deep${m.stopped ? "; the program's motion stopped" : ""}`;
      }
      return `event ${m.event}${m.command ? " " + m.command : ""}${m.id ? " #" + m.id : ""}${m.node ? " @" + m.node : ""}`;
    case "ack":
      return `ack #${m.id} ${m.status}`;
    case "error":
      return `error ${m.code}: ${m.message}`;
  }
}

export function useControlSocket(log: (line: string) => void): (command: Command) => void {
  const socket = useRef<WebSocket | null>(null);
  useEffect(() => {
    let closed = false;
    const connect = () => {
      const ws = new WebSocket(wsUrl("/ws/control"));
      socket.current = ws;
      ws.onmessage = (ev) => log(describeControlMessage(JSON.parse(ev.data) as ControlMessage));
      // a restarted server, or a token typed in after a refusal (4401): connect again
      ws.onclose = () => { if (!closed) window.setTimeout(connect, RECONNECT_MS); };
    };
    connect();
    return () => { closed = true; socket.current?.close(); };
  }, [log]);
  return useCallback((command: Command) => {
    const ws = socket.current;
    log(`> ${JSON.stringify(command)}`);
    if (ws && ws.readyState === WebSocket.OPEN) ws.send(JSON.stringify(command));
    else api.command(command).catch((e) => log(`error ${e}`));
  }, [log]);
}
