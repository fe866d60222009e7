// The editor's page: the top bar, the graph, and the registered panels in their areas.
import { GraphView } from "./GraphView";
import { PANELS, type Area } from "./panels";
import { Toolbar } from "./Toolbar";

function PanelsIn({ area }: { area: Area }) {
  return <>{PANELS.filter((p) => p.area === area).map(({ id, Component }) => <Component key={id} />)}</>;
}

export function Layout() {
  return (
    <div className="app">
      <Toolbar />
      <aside className="left"><PanelsIn area="left" /></aside>
      <GraphView />
      <aside className="right"><PanelsIn area="right" /></aside>
      <section className="bottom">
        <div className="previz"><PanelsIn area="previz" /></div>
        <div className="livecol">
          <PanelsIn area="live" />
          <div className="controls-strip" data-testid="controls"><PanelsIn area="controls" /></div>
          <PanelsIn area="log" />
        </div>
      </section>
    </div>
  );
}
