pub mod colour_range;
pub mod crack_plots;
pub mod curve;
pub mod damage_map;
mod font;
pub mod history_plots;
pub mod map_nodes;
pub mod morris_plot;
