// The editor's audio: the robot's sounds played through Web Audio (fetched from their `url`, decoded
// once per URL) and speech without a recording previewed by the browser's speech synthesis. The live
// Pre-Viz and the behaviour editor's preview both play through here, so one mute switch and one
// AudioContext serve both. Browsers start audio only after a user gesture: `unlock()` from a click.

/** One sound or utterance started, for the status line and the browser tests (window.__nuttyAudio). */
export interface AudioLogEntry {
  kind: "sound" | "speech";
  /** the sound's name, or the spoken text */
  what: string;
  /** performance.now() (ms) when its first sample is due at the speakers */
  at: number;
  /** s into the sound it started from (a late event starts part-way, to stay with the motion) */
  offset: number;
  /** the engine's frame time (s) of the event, when it came from one */
  t?: number;
}

let context: AudioContext | null = null;
const buffers = new Map<string, Promise<AudioBuffer>>();
const playing = new Set<AudioBufferSourceNode>();
let muted = false;
const log: AudioLogEntry[] = [];
(globalThis as { __nuttyAudio?: AudioLogEntry[] }).__nuttyAudio = log;

export function audioContext(): AudioContext {
  context ??= new AudioContext({ latencyHint: "interactive" });
  return context;
}

/** Resume audio after a user gesture (browsers keep a new AudioContext suspended until one). */
export function unlock(): Promise<void> {
  return audioContext().resume();
}

export const audioRunning = () => context?.state === "running";
// the browser tests wait for audio to run before they listen for it
(globalThis as { __nuttyAudioState?: () => string }).__nuttyAudioState = () => context?.state ?? "none";

export function setMuted(value: boolean): void {
  muted = value;
  if (muted) stopAll();
}

export const isMuted = () => muted;

/** The decoded sound at `url` (fetched and decoded once; a failure is retried next time). */
export function loadSound(url: string): Promise<AudioBuffer> {
  let buffer = buffers.get(url);
  if (!buffer) {
    buffer = fetch(url)
      .then((r) => {
        if (!r.ok) throw new Error(`${url}: ${r.status}`);
        return r.arrayBuffer();
      })
      .then((bytes) => audioContext().decodeAudioData(bytes));
    buffer.catch(() => buffers.delete(url));
    buffers.set(url, buffer);
  }
  return buffer;
}

/** The output's delay (s) from starting a source to hearing it. */
export function outputLatency(): number {
  const ctx = audioContext();
  return (ctx.baseLatency || 0) + (ctx.outputLatency || 0);
}

/**
 * Play a decoded sound now, `offset` s into it (a negative offset waits that long first). Returns a
 * function that stops it. Nothing plays while muted.
 */
export function playBuffer(buffer: AudioBuffer, what: string, offset = 0, t?: number): () => void {
  if (muted || offset >= buffer.duration) return () => {};
  const ctx = audioContext();
  const source = ctx.createBufferSource();
  source.buffer = buffer;
  source.connect(ctx.destination);
  const wait = Math.max(0, -offset);
  source.start(ctx.currentTime + wait, Math.max(0, offset));
  playing.add(source);
  source.onended = () => playing.delete(source);
  log.push({ kind: "sound", what, at: performance.now() + (wait + outputLatency()) * 1000, offset: Math.max(0, offset), t });
  return () => {
    try {
      source.stop();
    } catch {
      // already stopped: nothing to do
    }
    playing.delete(source);
  };
}

/** Speak a text with the browser's voice (speech without a recording). */
export function speak(text: string, t?: number): () => void {
  if (muted || typeof speechSynthesis === "undefined") return () => {};
  const utterance = new SpeechSynthesisUtterance(text);
  speechSynthesis.speak(utterance);
  log.push({ kind: "speech", what: text, at: performance.now(), offset: 0, t });
  return () => speechSynthesis.cancel();
}

export function stopAll(): void {
  for (const source of playing) {
    try {
      source.stop();
    } catch {
      // already stopped
    }
  }
  playing.clear();
  if (typeof speechSynthesis !== "undefined") speechSynthesis.cancel();
}

export const audioLog = (): readonly AudioLogEntry[] => log;
