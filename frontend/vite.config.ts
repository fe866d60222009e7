import { defineConfig } from "vite";
import react from "@vitejs/plugin-react";

// The editor is served by the FastAPI server at "/"; `npm run dev` proxies the API to it.
export default defineConfig({
  plugins: [react()],
  root: ".",
  build: { outDir: "dist", emptyOutDir: true, chunkSizeWarningLimit: 2000 },
  server: {
    proxy: {
      "/api": "http://127.0.0.1:8000",
      "/ws": { target: "ws://127.0.0.1:8000", ws: true },
    },
  },
  test: { environment: "node", include: ["node_editor/**/*.test.ts"] },
});
