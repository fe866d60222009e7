// What a document editor's toolbar (the clip editor's, the behaviour editor's) shows of its working copy:
// its name and unsaved mark, its undo history and saving.
export interface DocumentBarProps {
  name: string;
  dirty: boolean;
  canUndo: boolean;
  canRedo: boolean;
  undoLabel: string;
  redoLabel: string;
  undo: () => void;
  redo: () => void;
  save: () => void;
  saving: boolean;
}
