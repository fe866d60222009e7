// ESLint for the editor (`npm run lint` runs it with `tsc --noEmit` and the import-cycle check):
// ESLint's and typescript-eslint's recommended rules everywhere, and React's hooks rules (the plugin's
// recommended set: the rules of hooks, exhaustive deps and the React Compiler's checks) on the editor.
// Types are tsc's job, so the TypeScript rules are the recommended ones that need no type information.
// A rule is switched off for one line only, by name and with its reason after `--`.
import comments from "@eslint-community/eslint-plugin-eslint-comments/configs";
import js from "@eslint/js";
import { defineConfig, globalIgnores } from "eslint/config";
import reactHooks from "eslint-plugin-react-hooks";
import globals from "globals";
import tseslint from "typescript-eslint";

export default defineConfig(
  // the build's output, and the types generated from the backend (`npm run gen:types`, never hand-edited)
  globalIgnores(["dist/", "node_editor/generated/"]),
  { linterOptions: { reportUnusedDisableDirectives: "error" } },
  js.configs.recommended,
  tseslint.configs.recommended,
  comments.recommended,
  {
    rules: {
      // every `eslint-disable` names its rules (no-unlimited-disable, above) and says why
      "@eslint-community/eslint-comments/require-description": ["error", { ignore: ["eslint-enable"] }],
      // `const { inside: _, ...rest } = meta` is how a key is left out of a copy
      "@typescript-eslint/no-unused-vars": ["error", { ignoreRestSiblings: true }],
    },
  },
  {
    files: ["node_editor/**/*.{ts,tsx}"],
    extends: [reactHooks.configs.flat.recommended],
    languageOptions: { globals: globals.browser },
  },
  {
    // the build's and the tools' own scripts run in Node
    files: ["*.config.{js,ts}", "scripts/**/*.mjs"],
    languageOptions: { globals: globals.node },
  },
);
