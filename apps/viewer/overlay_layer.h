/// \file overlay_layer.h
/// \brief Overlays (correspondences, Delaunay edges, walk paths) drawn in a second VTK renderer
/// layer that shares the main camera: the layer's depth buffer starts empty, so an overlay is never
/// hidden behind the clouds. A walk runs through the target, usually behind the source surface,
/// and would otherwise be invisible exactly when it is interesting.
#pragma once

#include <vtkActor.h>
#include <vtkPointData.h>
#include <vtkPolyData.h>
#include <vtkPolyDataMapper.h>
#include <vtkProperty.h>
#include <vtkRenderWindow.h>
#include <vtkRenderer.h>
#include <vtkSmartPointer.h>

#include <array>
#include <map>
#include <string>

namespace dw_viewer {

class OverlayLayer {
 public:
  /// \param[in] window the render window of the visualiser
  /// \param[in] main the visualiser's renderer, whose camera the overlay follows
  OverlayLayer(vtkRenderWindow* window, vtkRenderer* main) : renderer_(vtkSmartPointer<vtkRenderer>::New()) {
    window->SetNumberOfLayers(2);
    renderer_->SetLayer(1);
    renderer_->InteractiveOff();  // picking and camera interaction stay with the main layer
    renderer_->SetActiveCamera(main->GetActiveCamera());
    window->AddRenderer(renderer_);
  }

  /// Adds or replaces overlay `id`. Without per-point scalars it is drawn in `rgb`.
  /// \param[in] size line width or point size in pixels
  void set(const std::string& id, vtkSmartPointer<vtkPolyData> poly, const std::array<double, 3>& rgb,
           double size, double opacity = 1.0) {
    remove(id);
    auto mapper = vtkSmartPointer<vtkPolyDataMapper>::New();
    mapper->SetInputData(poly);
    const bool has_colours = poly->GetPointData() && poly->GetPointData()->GetScalars();
    mapper->SetScalarVisibility(has_colours);
    if (has_colours) mapper->SetColorModeToDirectScalars();
    auto actor = vtkSmartPointer<vtkActor>::New();
    actor->SetMapper(mapper);
    actor->GetProperty()->SetColor(rgb[0], rgb[1], rgb[2]);
    actor->GetProperty()->SetLineWidth(static_cast<float>(size));
    actor->GetProperty()->SetPointSize(static_cast<float>(size));
    actor->GetProperty()->SetOpacity(opacity);
    actor->GetProperty()->LightingOff();  // flat colours: overlays are markers, not surfaces
    renderer_->AddActor(actor);
    actors_[id] = actor;
  }

  void remove(const std::string& id) {
    auto it = actors_.find(id);
    if (it == actors_.end()) return;
    renderer_->RemoveActor(it->second);
    actors_.erase(it);
  }

 private:
  vtkSmartPointer<vtkRenderer> renderer_;
  std::map<std::string, vtkSmartPointer<vtkActor>> actors_;
};

}  // namespace dw_viewer
