// Layout numbers shared by the canvas's modules, in flow pixels (px at zoom 1) unless said otherwise.
// Several restate what styles.css draws (the selector is named): a change there changes them too.
// Numbers only one module uses are named at the top of that module.

// ---- a block on the canvas (BlockNode, SubgraphNode draw it; GraphView's auto-layout makes room for it)

/** A block's width: .block's min-width (236) and its borders, rounded up. */
export const BLOCK_WIDTH = 240;
/** A block's header (.block-header: a 16 px name over an 11 px type, its padding and the border), about;
 * its body is below. */
export const BLOCK_HEADER_HEIGHT = 46;
/** One row of ports (.port-row): an input on the left and an output on the right share a row. */
export const PORT_ROW_HEIGHT = 22;
/** The first port row's top in the block's body. */
export const PORT_ROWS_TOP = 6;
/** A port's handle sits halfway down its row. */
export const HANDLE_TOP = PORT_ROW_HEIGHT / 2;
/** One live-value row under the ports (.live-row), one per output. */
export const LIVE_ROW_HEIGHT = 18;
/** One row of a mixer's layer list (.layer-row), and the list's padding and border (.layers, rounded up). */
export const LAYER_ROW_HEIGHT = 18;
export const LAYERS_PADDING = 12;

/** A block put at the pointer (quick-add, Shift+D, the menu's Duplicate) has its corner here from the
 * pointer (flow px): centred on it, its title under it. */
export const AT_POINTER = { x: -BLOCK_WIDTH / 2, y: -20 };

// ---- new blocks: never dropped onto another one (store/state.ts, subgraphs.ts)

/** A new block this close to another one's top-left corner (both ways) would cover it… */
export const NEW_BLOCK_CLEARANCE = { x: BLOCK_WIDTH, y: 140 };
/** …so it moves down by this much until it is clear. */
export const NEW_BLOCK_STEP = 150;

// ---- over the canvas (screen px)

/** Menus and the quick-add search keep this far inside the canvas's edges. */
export const MENU_EDGE_MARGIN = 4;
/** The canvas's size when it cannot be measured (not laid out yet). */
export const FALLBACK_CANVAS_SIZE = { width: 800, height: 600 };
/** The minimap's size (styles.css sizes .react-flow__minimap the same). */
export const MINIMAP_SIZE = { width: 180, height: 110 };

// ---- dragged from the palette onto the canvas (dataTransfer types)

/** A block type (panels/Palette) and a library subgraph, `{name, definition}` as JSON (panels/SubgraphLibrary). */
export const DRAG_BLOCK = "application/nutty-block";
export const DRAG_SUBGRAPH = "application/nutty-subgraph";
