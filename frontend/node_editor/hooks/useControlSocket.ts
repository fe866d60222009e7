// The control WebSocket: commands go out on it (over REST while it is not open), and its acks, errors
// and events become console lines.
import { useCallback, useEffect, useRef } from "react";
import { api, wsUrl, type Command, type ControlMessage } from "../api";

/** A console line for a message of /ws/control. */
export function describeControlMessage(m: ControlMessage): string {
  switch (m.type) {
    case "event":
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
    const ws = new WebSocket(wsUrl("/ws/control"));
    socket.current = ws;
    ws.onmessage = (ev) => log(describeControlMessage(JSON.parse(ev.data) as ControlMessage));
    return () => ws.close();
  }, [log]);
  return useCallback((command: Command) => {
    const ws = socket.current;
    log(`> ${JSON.stringify(command)}`);
    if (ws && ws.readyState === WebSocket.OPEN) ws.send(JSON.stringify(command));
    else api.command(command).catch((e) => log(`error ${e}`));
  }, [log]);
}
